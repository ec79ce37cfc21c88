#include "controllers/controller.h"

#include <cerrno>
#include <cstdlib>
#include <stdexcept>

#include "host/timers.h"

namespace dca {

ParamSpec ParamSpec::Required(std::string name, std::string type, std::string doc) {
  return {std::move(name), std::move(type), "", true, false, std::move(doc)};
}
ParamSpec ParamSpec::Optional(std::string name, std::string type, std::string def, std::string doc) {
  return {std::move(name), std::move(type), std::move(def), false, false, std::move(doc)};
}
ParamSpec ParamSpec::Number(std::string name, std::string def, std::string doc) {
  return Optional(std::move(name), "number", std::move(def), std::move(doc));
}
ParamSpec ParamSpec::Variadic(std::string name, std::string type, std::string doc) {
  return {std::move(name), std::move(type), "", false, true, std::move(doc)};
}

std::string_view to_string(Ending::Kind k) {
  switch (k) {
    case Ending::Kind::Never: return "never";
    case Ending::Kind::Done: return "done";
    case Ending::Kind::Aborted: return "aborted";
    case Ending::Kind::DoneOrAborted: return "done or aborted";
    case Ending::Kind::Unspecified: break;
  }
  return "";
}

Controller::Controller(const ControllerContext& ctx) : ctx_(ctx) {
  if (!ctx.manifest) throw std::invalid_argument("controller '" + ctx.name + "' built without a manifest (use the registry)");
  manifest_ = *ctx.manifest;
  ctx_.manifest = &manifest_;
  for (const auto& p : manifest_.inputs) ports_.add_input(p);
  for (const auto& p : manifest_.outputs) ports_.add_output(p);
  // Too many arguments is an error (too few is checked when a parameter is read).
  const bool variadic = !manifest_.params.empty() && manifest_.params.back().variadic;
  if (!variadic && ctx_.params.size() > manifest_.params.size())
    throw std::invalid_argument(manifest_.type + " " + ctx_.name + ": " + std::to_string(ctx_.params.size()) +
                                " parameters given, at most " + std::to_string(manifest_.params.size()) + " expected");
}

Controller::~Controller() {
  for (auto* in : triggers_) in->on_sample = nullptr;
  if (timer_ && ctx_.timers) ctx_.timers->cancel(timer_);
}

Nanos Controller::now() const { return timers().now(); }

TimerServer& Controller::timers() const {
  if (!ctx_.timers) throw std::logic_error("controller '" + ctx_.name + "' has no TimerServer");
  return *ctx_.timers;
}

Input& Controller::input(std::string_view name) {
  if (auto* p = ports_.find_input(name)) return *p;
  throw std::invalid_argument(ports_.no_such_input(ctx_.name.empty() ? manifest_.type : ctx_.name, name));
}

Output& Controller::output(std::string_view name) {
  if (auto* p = ports_.find_output(name)) return *p;
  throw std::invalid_argument(ports_.no_such_output(ctx_.name.empty() ? manifest_.type : ctx_.name, name));
}

const ParamSpec* Controller::param(std::string_view name, std::size_t& index) const {
  for (std::size_t i = 0; i < manifest_.params.size(); ++i)
    if (manifest_.params[i].name == name) {
      index = i;
      return &manifest_.params[i];
    }
  throw std::logic_error(manifest_.type + ": no parameter '" + std::string(name) + "' in its manifest");
}

std::string Controller::raw_param(std::string_view name, const ParamSpec*& spec) const {
  std::size_t i = 0;
  spec = param(name, i);
  if (i < ctx_.params.size()) return ctx_.params[i];
  if (spec->required)
    throw std::invalid_argument(manifest_.type + " " + ctx_.name + ": parameter " + std::to_string(i + 1) + " '" +
                                spec->name + "' is required");
  return spec->default_value;
}

namespace {
double parse_number(const std::string& s, bool& ok) {
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  ok = !s.empty() && end && *end == '\0' && errno == 0;
  return v;
}
}  // namespace

double Controller::number(std::string_view name) const {
  const ParamSpec* spec = nullptr;
  const std::string s = raw_param(name, spec);
  bool ok = false;
  const double v = parse_number(s, ok);
  if (!ok)
    throw std::invalid_argument(manifest_.type + " " + ctx_.name + ": parameter '" + spec->name +
                                "' must be a number, got '" + s + "'");
  return v;
}

std::int64_t Controller::integer(std::string_view name) const {
  const ParamSpec* spec = nullptr;
  const std::string s = raw_param(name, spec);
  errno = 0;
  char* end = nullptr;
  const long long v = std::strtoll(s.c_str(), &end, 10);
  if (s.empty() || !end || *end != '\0' || errno != 0)
    throw std::invalid_argument(manifest_.type + " " + ctx_.name + ": parameter '" + spec->name +
                                "' must be an integer, got '" + s + "'");
  return v;
}

std::string Controller::text(std::string_view name) const {
  const ParamSpec* spec = nullptr;
  return raw_param(name, spec);
}

std::vector<double> Controller::numbers(std::string_view name) const {
  std::size_t i = 0;
  const ParamSpec* spec = param(name, i);
  std::vector<double> v;
  for (std::size_t j = i; j < ctx_.params.size(); ++j) {
    bool ok = false;
    v.push_back(parse_number(ctx_.params[j], ok));
    if (!ok)
      throw std::invalid_argument(manifest_.type + " " + ctx_.name + ": parameter '" + spec->name + "' (argument " +
                                  std::to_string(j + 1) + ") must be a number, got '" + ctx_.params[j] + "'");
  }
  return v;
}

double Controller::checked(std::string_view name, bool ok_when_zero) const {
  const double v = number(name);
  if (v > 0 || (ok_when_zero && v == 0)) return v;
  throw bad_param("parameter '" + std::string(name) + "' must be " + (ok_when_zero ? "at least 0" : "positive") +
                  ", got " + text(name));
}
double Controller::positive(std::string_view name) const { return checked(name, false); }
double Controller::non_negative(std::string_view name) const { return checked(name, true); }

std::invalid_argument Controller::bad_param(const std::string& what) const {
  return std::invalid_argument(manifest_.type + " " + ctx_.name + ": " + what);
}

bool Controller::fail(std::string* error, const std::string& what) const {
  if (error) *error = manifest_.type + " " + ctx_.name + what;
  return false;
}

bool Controller::configure(std::string* error) {
  if (state_ == State::Running) halt();
  try {
    Init();
  } catch (const std::exception& e) {
    return fail(error, std::string(": Init failed: ") + e.what());
  }
  state_ = State::Ready;
  return true;
}

bool Controller::start(Bytes init_value, std::string* error) {
  if (state_ == State::Running) return fail(error, " is already running");
  if (state_ != State::Ready && !configure(error)) return false;
  ticks_ = 0;
  state_ = State::Running;
  try {
    msgpack::object_handle oh;
    if (!init_value.empty()) oh = msgpack::unpack(reinterpret_cast<const char*>(init_value.data()), init_value.size());
    Run(oh.get());
  } catch (const std::exception& e) {
    StopTimer();
    state_ = State::Ready;
    return fail(error, std::string(": Run failed: ") + e.what());
  }
  return true;
}

void Controller::halt() {
  if (state_ == State::Running || state_ == State::Ready) {
    StopTimer();
    for (auto* in : triggers_) in->on_sample = nullptr;
    triggers_.clear();
    try {
      Stop();
    } catch (const std::exception& e) {
      std::fprintf(stderr, "dca: %s %s: Stop failed: %s\n", manifest_.type.c_str(), ctx_.name.c_str(), e.what());
    }
    state_ = State::Stopped;
  }
}

void Controller::tick() {
  if (state_ != State::Running) return;
  if (in_main_calc_) {
    ++reentries_;
    return;
  }
  in_main_calc_ = true;
  ++ticks_;
  MainCalc();
  in_main_calc_ = false;
}

void Controller::StartPeriodic(double seconds) {
  StopTimer();
  timer_ = timers().every(from_seconds(seconds), [this] { tick(); }, ctx_.name);
}

void Controller::StartOneShot(double seconds) {
  StopTimer();
  timer_ = timers().after(from_seconds(seconds), [this] {
    timer_ = 0;
    tick();
  }, ctx_.name);
}

void Controller::StopTimer() {
  if (timer_ && ctx_.timers) ctx_.timers->cancel(timer_);
  timer_ = 0;
}

void Controller::TriggerOn(Input& in) {
  in.on_sample = [this] { tick(); };
  triggers_.push_back(&in);
}

void Controller::Done() {
  static const std::string nil(1, '\xc0');
  finish({ComponentEvent::Kind::Done, nil, ""});
}

void Controller::Done(double v) { DoneWith(v); }
void Controller::Done(std::string_view v) { DoneWith(std::string(v)); }

void Controller::Abort(std::string reason) { finish({ComponentEvent::Kind::Aborted, "", std::move(reason)}); }

void Controller::finish(ComponentEvent e) {
  if (state_ != State::Running) return;  // after Stop, or a second Done/Abort: ignored
  halt();
  state_ = State::Finished;
  if (on_event) on_event(e);
}

ParamSpec PeriodicController::PeriodParam(std::string def, std::string doc) {
  return ParamSpec::Optional("period", "number", std::move(def), std::move(doc));
}

PeriodicController::PeriodicController(const ControllerContext& ctx, Period mode)
    : Controller(ctx), period_(mode == Period::Positive ? positive("period") : non_negative("period")) {}

void PeriodicController::Run(const msgpack::object&) {
  started_ = now();
  if (period_ > 0) return StartPeriodic(period_);
  for (auto* in : triggers_) TriggerOn(*in);
  if (triggers_.empty()) MainCalc();
}

void PeriodicController::Stop() {
  for (auto* out : actuators_) out->write(Eigen::VectorXd::Zero(out->spec().size));
}

Output& PeriodicController::actuator(std::string_view name) {
  auto& out = output(name);
  actuators_.push_back(&out);
  return out;
}

Input& PeriodicController::trigger(std::string_view name) {
  auto& in = input(name);
  triggers_.push_back(&in);
  return in;
}

}  // namespace dca
