#include "controllers/controller.h"

#include <cerrno>
#include <cstdlib>
#include <stdexcept>

namespace dca {

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

std::string Controller::init() {
  if (state_ == State::Running) stop();
  try {
    Init();
  } catch (const std::exception& e) {
    return manifest_.type + " " + ctx_.name + ": Init failed: " + e.what();
  }
  state_ = State::Ready;
  return "";
}

std::string Controller::run(Bytes init_value) {
  if (state_ == State::Running) return manifest_.type + " " + ctx_.name + " is already running";
  if (state_ != State::Ready) {
    auto err = init();
    if (!err.empty()) return err;
  }
  ticks_ = 0;
  state_ = State::Running;
  try {
    msgpack::object_handle oh;
    if (!init_value.empty()) oh = msgpack::unpack(reinterpret_cast<const char*>(init_value.data()), init_value.size());
    Run(oh.get());
  } catch (const std::exception& e) {
    StopTimer();
    state_ = State::Ready;
    return manifest_.type + " " + ctx_.name + ": Run failed: " + e.what();
  }
  return "";
}

void Controller::stop() {
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
  stop();
  state_ = State::Finished;
  if (on_event) on_event(e);
}

}  // namespace dca
