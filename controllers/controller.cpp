#include <dca/controller.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>

#include "host/port.h"
#include "host/timers.h"

namespace dca {

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

// ------------------------------------------------------------------------------------------ the states ---

bool Controller::legal(State from, State to) {
  switch (to) {
    case State::Ready: return from != State::Running;
    case State::Running: return from == State::Ready;
    case State::Finished: return from == State::Running;
    case State::Stopped: return from == State::Ready || from == State::Running;
    case State::Idle: break;
  }
  return false;
}

std::string_view Controller::to_string(State s) {
  switch (s) {
    case State::Idle: return "idle";
    case State::Ready: return "ready";
    case State::Running: return "running";
    case State::Finished: return "finished";
    case State::Stopped: return "stopped";
  }
  return "?";
}

// --------------------------------------------------------------------------------- making, parameters ---

Controller::Controller(const ControllerContext& ctx) : ctx_(ctx), ports_(std::make_unique<PortSet>()) {
  if (!ctx.manifest) throw std::invalid_argument("controller '" + ctx.name + "' built without a manifest (use the registry)");
  manifest_ = *ctx.manifest;
  ctx_.manifest = &manifest_;
  for (const auto& p : manifest_.inputs) {
    auto& in = ports_->add_input(p);
    if (p.trigger) triggers_.push_back(&in);
  }
  for (const auto& p : manifest_.outputs) {
    auto& out = ports_->add_output(p);
    if (p.actuator) actuators_.push_back(&out);
  }
  // Too many arguments is an error (too few: a required one missing, found by check_params).
  const bool variadic = !manifest_.params.empty() && manifest_.params.back().variadic;
  if (!variadic && ctx_.params.size() > manifest_.params.size())
    throw std::invalid_argument(manifest_.type + " " + ctx_.name + ": " + std::to_string(ctx_.params.size()) +
                                " parameters given, at most " + std::to_string(manifest_.params.size()) + " expected");
  check_params();
}

Controller::~Controller() {
  for (auto* in : armed_) in->on_sample = nullptr;
  if (timer_ && ctx_.timers) ctx_.timers->cancel(timer_);
}

Nanos Controller::now() const { return timers().now(); }

TimerServer& Controller::timers() const {
  if (!ctx_.timers) throw std::logic_error("controller '" + ctx_.name + "' has no TimerServer");
  return *ctx_.timers;
}

namespace {
// A port bound in a constructor must be the manifest's, of the bound type: std::invalid_argument otherwise, as for
// a bad parameter, so that the node's start fails at once naming it (not a stand-in that aborts when it runs).
template <class P>
P& bound(P* p, const std::string& who, std::string_view name, PortType type, std::uint32_t size,
         const std::string& missing) {
  if (!p) throw std::invalid_argument(missing + " (list it in Describe())");
  if (p->spec().type != type || (type == PortType::Vector && p->spec().size != size))
    throw std::invalid_argument(who + ": port '" + std::string(name) + "' is " + describe_type(p->spec()) +
                           " in the manifest but bound as " + describe_type(PortSpec{"", type, size}));
  return *p;
}
}  // namespace

Input& Controller::input(std::string_view name, PortType type, std::uint32_t size) {
  const std::string who = ctx_.name.empty() ? manifest_.type : ctx_.name;
  return bound(ports_->find_input(name), who, name, type, size, ports_->no_such_input(who, name));
}

Output& Controller::output(std::string_view name, PortType type, std::uint32_t size) {
  const std::string who = ctx_.name.empty() ? manifest_.type : ctx_.name;
  return bound(ports_->find_output(name), who, name, type, size, ports_->no_such_output(who, name));
}

std::string range_text(const ParamSpec& p) {
  const auto n = [](double v) { return format_number(v); };
  if (p.max && (p.min || p.above))
    return "in " + (p.above ? "(" + n(*p.above) : "[" + n(*p.min)) + ", " + n(*p.max) + "]";
  if (p.max) return "at most " + n(*p.max);
  if (p.above) return *p.above == 0 ? "positive" : "above " + n(*p.above);
  if (p.min) return "at least " + n(*p.min);
  return "";
}

namespace {
double parse_number(const std::string& s, bool& ok) {
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  ok = !s.empty() && end && *end == '\0' && errno == 0;
  return v;
}

bool parse_integer(const std::string& s, std::int64_t& v) {
  errno = 0;
  char* end = nullptr;
  v = std::strtoll(s.c_str(), &end, 10);
  return !s.empty() && end && *end == '\0' && errno == 0;
}


bool in_range(const ParamSpec& p, double v) {
  return !(p.min && v < *p.min) && !(p.max && v > *p.max) && !(p.above && v <= *p.above);
}

// "a, b or c".
std::string one_of(const std::vector<std::string>& allowed) {
  std::string s;
  for (std::size_t i = 0; i < allowed.size(); ++i)
    s += (i == 0 ? "" : i + 1 == allowed.size() ? " or " : ", ") + allowed[i];
  return s;
}

// Why the text `s` is no value of parameter `p` ("" when it is one).
std::string bad_value(const ParamSpec& p, const std::string& s) {
  const std::string what = "parameter '" + p.name + "' must be ";
  if (p.type == "string") {
    for (const auto& a : p.allowed)
      if (a == s) return "";
    return p.allowed.empty() ? "" : what + one_of(p.allowed) + ", got '" + s + "'";
  }
  bool ok = false;
  double v = 0;
  if (p.type == "integer") {
    std::int64_t i = 0;
    ok = parse_integer(s, i);
    v = static_cast<double>(i);
    if (!ok) return what + "an integer, got '" + s + "'";
  } else {
    v = parse_number(s, ok);
    if (!ok) return what + "a number, got '" + s + "'";
  }
  return in_range(p, v) ? "" : what + range_text(p) + ", got " + s;
}
}  // namespace

void Controller::check_params() const {
  const auto& ps = manifest_.params;
  for (std::size_t i = 0; i < ps.size(); ++i) {
    const auto& p = ps[i];
    if (p.variadic) {
      for (std::size_t j = i; j < ctx_.params.size(); ++j)
        if (auto why = bad_value(p, ctx_.params[j]); !why.empty())
          throw bad_param(why.insert(why.find(" must"), " (argument " + std::to_string(j + 1) + ")"));
      continue;
    }
    if (i >= ctx_.params.size() && p.required)
      throw bad_param("parameter " + std::to_string(i + 1) + " '" + p.name + "' is required");
    if (auto why = bad_value(p, i < ctx_.params.size() ? ctx_.params[i] : p.default_value); !why.empty())
      throw bad_param(why);
  }
}

namespace {
std::size_t param_index(const Manifest& m, std::string_view name) {
  for (std::size_t i = 0; i < m.params.size(); ++i)
    if (m.params[i].name == name) return i;
  throw std::invalid_argument(m.type + ": no parameter '" + std::string(name) + "' in its manifest (list it in Describe())");
}
}  // namespace

std::string Controller::text(std::string_view name) const {
  const std::size_t i = param_index(manifest_, name);
  return i < ctx_.params.size() ? ctx_.params[i] : manifest_.params[i].default_value;
}

double Controller::number(std::string_view name) const {
  bool ok = false;
  return parse_number(text(name), ok);  // checked by check_params
}

std::int64_t Controller::integer(std::string_view name) const {
  std::int64_t v = 0;
  parse_integer(text(name), v);  // checked by check_params
  return v;
}

std::vector<double> Controller::numbers(std::string_view name) const {
  std::vector<double> v;
  for (std::size_t j = param_index(manifest_, name); j < ctx_.params.size(); ++j) {
    bool ok = false;
    v.push_back(parse_number(ctx_.params[j], ok));
  }
  return v;
}

std::invalid_argument Controller::bad_param(const std::string& what) const {
  return std::invalid_argument(manifest_.type + " " + ctx_.name + ": " + what);
}

// ----------------------------------------------------------------------------------- live parameters ---

std::string Controller::on_parameter(std::string_view name) {
  return manifest_.type + " has no on_parameter() to take '" + std::string(name) + "'";
}

// Checked as at construction (bad_value), stored, then the type's hook; its refusal (or throw) restores the old
// value. Runs on the node's loop thread, between two ticks: never during MainCalc.
bool Controller::set_parameter(std::string_view name, const std::string& text, std::string* error) {
  const auto& ps = manifest_.params;
  std::size_t i = 0;
  while (i < ps.size() && ps[i].name != name) ++i;
  if (i == ps.size()) {
    std::string names;
    for (const auto& p : ps) names += (names.empty() ? "" : ", ") + p.name;
    return fail(error, ": no parameter '" + std::string(name) + "' (parameters: " +
                           (names.empty() ? std::string("none") : names) + ")");
  }
  const auto& p = ps[i];
  if (!p.live || p.variadic)
    return fail(error, ": parameter '" + p.name + "' is not live: it changes at the leaf's next start");
  if (in_main_calc_) return fail(error, ": parameter '" + p.name + "' cannot change during MainCalc");
  if (auto why = bad_value(p, text); !why.empty()) return fail(error, ": " + why);
  if (auto why = change_param(i, text); !why.empty())
    return fail(error, ": parameter '" + p.name + "' not changed: " + why);
  return true;
}

// Stores `text` as parameter i and calls the hook: "" when it took it, else why not (the old value restored; after
// a throw the hook reads the old value again).
std::string Controller::change_param(std::size_t i, const std::string& text) {
  const std::size_t given = ctx_.params.size();
  const std::string old = i < given ? ctx_.params[i] : manifest_.params[i].default_value;
  for (std::size_t j = given; j <= i; ++j) ctx_.params.push_back(manifest_.params[j].default_value);
  ctx_.params[i] = text;
  const std::string& name = manifest_.params[i].name;
  std::string why;
  bool threw = false;
  try {
    why = on_parameter(name);
  } catch (const std::exception& e) {
    why = std::string("on_parameter failed: ") + e.what();
    threw = true;
  }
  if (why.empty()) return "";
  ctx_.params[i] = old;
  ctx_.params.resize(given);  // an absent argument stays absent: its default again
  if (threw) {
    try {
      (void)on_parameter(name);
    } catch (const std::exception&) {  // it threw with the new value: the old one is its members' as before
    }
  }
  return why;
}

// ---------------------------------------------------------------------------------- the life cycle ---

bool Controller::fail(std::string* error, const std::string& what) const {
  if (error) *error = manifest_.type + " " + ctx_.name + what;
  return false;
}

bool Controller::configure(std::string* error) {
  if (!broken_.empty()) return fail(error, ": " + broken_);
  if (state_ == State::Running) halt();
  if (!legal(state_, State::Ready)) return fail(error, " cannot be configured when " + std::string(to_string(state_)));
  try {
    on_configure();
  } catch (const std::exception& e) {
    return fail(error, std::string(": on_configure failed: ") + e.what());
  }
  state_ = State::Ready;
  return true;
}

bool Controller::start(Bytes init_value, std::string* error) {
  if (state_ == State::Running) return fail(error, " is already running");
  if (state_ != State::Ready && !configure(error)) return false;
  if (!legal(state_, State::Running)) return fail(error, " cannot start when " + std::string(to_string(state_)));
  ticks_ = 0;
  state_ = State::Running;
  try {
    started_ = ctx_.timers ? now() : 0;
    msgpack::object_handle oh;
    if (!init_value.empty()) oh = msgpack::unpack(reinterpret_cast<const char*>(init_value.data()), init_value.size());
    on_start(oh.get());
    if (state_ == State::Running) arm();  // unless on_start ended the run
  } catch (const std::exception& e) {
    StopTimer();
    for (auto* in : armed_) in->on_sample = nullptr;
    armed_.clear();
    state_ = State::Ready;
    return fail(error, std::string(": on_start failed: ") + e.what());
  }
  return true;
}

// The timer (PeriodicController with a period), else the triggers; event-driven without one: MainCalc once.
void Controller::arm() {
  if (period_ > 0) return StartPeriodic(period_);
  for (auto* in : triggers_) {
    in->on_sample = [this] { tick(); };
    armed_.push_back(in);
  }
  if (period_ == 0 && triggers_.empty()) MainCalc();
}

void Controller::release() {
  StopTimer();
  for (auto* in : armed_) in->on_sample = nullptr;
  armed_.clear();
  try {
    on_halt();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dca: %s %s: on_halt failed: %s\n", manifest_.type.c_str(), ctx_.name.c_str(), e.what());
  }
  for (auto* out : actuators_) {
    if (out->spec().type == PortType::Scalar) out->write(0.0);
    else if (out->message()) out->write_bytes(out->message()->zero());
    else out->write(Eigen::VectorXd::Zero(out->spec().size));
  }
}

void Controller::halt() {
  if (!legal(state_, State::Stopped)) return;  // idempotent: nothing to stop
  release();
  state_ = State::Stopped;
}

void Controller::finish(ComponentEvent e) {
  if (!legal(state_, State::Finished)) return;  // after halt, or a second Done/Abort: ignored
  release();
  state_ = State::Finished;
  if (on_event) on_event(e);
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

void Controller::Done() {
  static const std::string nil(1, '\xc0');
  finish({ComponentEvent::Kind::Done, nil, ""});
}

void Controller::Done(double v) { DoneWith(v); }
void Controller::Done(std::string_view v) { DoneWith(std::string(v)); }

void Controller::Abort(std::string reason) { finish({ComponentEvent::Kind::Aborted, "", std::move(reason)}); }

// ------------------------------------------------------------------------------- PeriodicController ---

Param<double> PeriodicController::PeriodParam(std::optional<double> def, std::string doc, Period mode) {
  Param<double> p{.name = "period", .doc = std::move(doc), .def = def};
  if (mode == Period::Positive) p.above = 0;
  else p.min = 0;
  return p;
}

PeriodicController::PeriodicController(const ControllerContext& ctx, Period mode) : Controller(ctx) {
  period_ = number("period");
  if (period_ > 0 || (mode == Period::ZeroIsEventDriven && period_ == 0)) return;
  throw bad_param("parameter 'period' must be " + std::string(mode == Period::Positive ? "positive" : "at least 0") +
                  ", got " + text("period"));
}

}  // namespace dca
