#include "controllers/builtins.h"

#include <csignal>
#include <cstdlib>
#include <stdexcept>

#include "controllers/registry.h"

namespace dca::builtins {

namespace {
ParamSpec required(std::string name, std::string type, std::string doc) {
  return {std::move(name), std::move(type), "", true, false, std::move(doc)};
}
ParamSpec optional(std::string name, std::string type, std::string def, std::string doc) {
  return {std::move(name), std::move(type), std::move(def), false, false, std::move(doc)};
}
ParamSpec variadic(std::string name, std::string type, std::string doc) {
  return {std::move(name), std::move(type), "", false, true, std::move(doc)};
}
double positive(double v, const std::string& what) {
  if (!(v > 0)) throw std::invalid_argument(what + " must be positive, got " + std::to_string(v));
  return v;
}
double non_negative(double v, const std::string& what) {
  if (!(v >= 0)) throw std::invalid_argument(what + " must not be negative, got " + std::to_string(v));
  return v;
}
}  // namespace

// --- Timer ---
Manifest Timer::Describe() {
  return {"Timer", "ends DONE with value \"timeout\" `seconds` after each start (SEMANTICS.md 12)", {}, {},
          {required("seconds", "number", "the timeout, in seconds")}};
}
Timer::Timer(const ControllerContext& ctx) : Controller(ctx), seconds_(non_negative(number("seconds"), "Timer seconds")) {}
void Timer::Run(const msgpack::object&) { StartOneShot(seconds_); }
void Timer::MainCalc() { Done(std::string_view("timeout")); }

// --- Deadline ---
Manifest Deadline::Describe() {
  return {"Deadline", "ends ABORTED `seconds` after each start (a timeout that counts as failure)", {}, {},
          {required("seconds", "number", "the deadline, in seconds")}};
}
Deadline::Deadline(const ControllerContext& ctx)
    : Controller(ctx), seconds_(non_negative(number("seconds"), "Deadline seconds")) {
  reason_ = "deadline of " + text("seconds") + " s passed";
}
void Deadline::Run(const msgpack::object&) { StartOneShot(seconds_); }
void Deadline::MainCalc() { Abort(reason_); }

// --- Constant ---
Manifest Constant::Describe() {
  return {"Constant", "writes constant values on Out every period (period 0: once, at start)", {},
          {vectorx_port("Out")},
          {required("period", "number", "seconds between writes; 0 writes once at start"),
           variadic("values", "number", "the values written (Out has as many elements)")}};
}
Constant::Constant(const ControllerContext& ctx)
    : Controller(ctx), out_(output("Out")), period_(non_negative(number("period"), "Constant period")) {
  const auto v = numbers("values");
  values_ = Eigen::Map<const Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size()));
}
void Constant::Run(const msgpack::object&) {
  if (period_ > 0) StartPeriodic(period_);
  else MainCalc();
}
void Constant::MainCalc() { out_.write(values_); }

// --- Gain ---
Manifest Gain::Describe() {
  return {"Gain", "Out = k * In, on each In sample (or every period)", {vectorx_port("In")}, {vectorx_port("Out")},
          {required("k", "number", "the gain"),
           optional("period", "number", "0", "seconds between computations; 0: on each In sample")}};
}
Gain::Gain(const ControllerContext& ctx)
    : Controller(ctx), in_(input("In")), out_(output("Out")), k_(number("k")),
      period_(non_negative(number("period"), "Gain period")) {
  y_.resize(64);  // grown (outside MainCalc's steady state) only for bigger samples
}
void Gain::Run(const msgpack::object&) {
  if (period_ > 0) StartPeriodic(period_);
  else TriggerOn(in_);
}
void Gain::MainCalc() {
  if (!in_.take_latest() && !in_.has_current()) return;
  const auto x = in_.vector();
  if (y_.size() < x.size()) y_.resize(x.size());
  auto y = y_.head(x.size());
  y.noalias() = k_ * x;
  out_.write(y);
}

// --- Sum ---
Manifest Sum::Describe() {
  return {"Sum", "Out = In1 + In2 (same sizes), on each input sample (or every period)",
          {vectorx_port("In1"), vectorx_port("In2")}, {vectorx_port("Out")},
          {optional("period", "number", "0", "seconds between computations; 0: on each sample")}};
}
Sum::Sum(const ControllerContext& ctx)
    : Controller(ctx), in1_(input("In1")), in2_(input("In2")), out_(output("Out")),
      period_(non_negative(number("period"), "Sum period")) {
  y_.resize(64);
}
void Sum::Run(const msgpack::object&) {
  if (period_ > 0) {
    StartPeriodic(period_);
  } else {
    TriggerOn(in1_);
    TriggerOn(in2_);
  }
}
void Sum::MainCalc() {
  in1_.take_latest();
  in2_.take_latest();
  if (!in1_.has_current() || !in2_.has_current()) return;
  const auto a = in1_.vector();
  const auto b = in2_.vector();
  if (a.size() != b.size()) return Abort("Sum: In1 has " + std::to_string(a.size()) + " values but In2 has " +
                                         std::to_string(b.size()));
  if (y_.size() < a.size()) y_.resize(a.size());
  auto y = y_.head(a.size());
  y.noalias() = a + b;
  out_.write(y);
}

// --- Threshold ---
Manifest Threshold::Describe() {
  return {"Threshold", "ends DONE with the value when In crosses the level", {scalar_port("In")}, {},
          {required("level", "number", "the level"),
           optional("direction", "string", "rising", "rising, falling or either")}};
}
Threshold::Threshold(const ControllerContext& ctx) : Controller(ctx), in_(input("In")), level_(number("level")) {
  const auto d = text("direction");
  if (d == "rising") direction_ = 1;
  else if (d == "falling") direction_ = -1;
  else if (d == "either") direction_ = 0;
  else throw std::invalid_argument("Threshold " + name() + ": direction must be rising, falling or either, got '" + d + "'");
}
void Threshold::Run(const msgpack::object&) {
  have_previous_ = false;
  TriggerOn(in_);
}
void Threshold::MainCalc() {
  while (in_.pop()) {
    const double v = in_.scalar();
    if (have_previous_) {
      const bool up = previous_ < level_ && v >= level_;
      const bool down = previous_ > level_ && v <= level_;
      if ((direction_ >= 0 && up) || (direction_ <= 0 && down)) return Done(v);
    }
    have_previous_ = true;
    previous_ = v;
  }
}

// --- Counter ---
Manifest Counter::Describe() {
  return {"Counter", "writes 1, 2, 3, ... on Count, one per tick; DONE(count) at the limit", {},
          {scalar_port("Count")},
          {required("period", "number", "seconds between ticks"),
           optional("limit", "integer", "0", "DONE when the count reaches it; 0: never")}};
}
Counter::Counter(const ControllerContext& ctx)
    : Controller(ctx), out_(output("Count")), period_(positive(number("period"), "Counter period")),
      limit_(integer("limit")) {}
void Counter::Run(const msgpack::object&) {
  count_ = 0;
  StartPeriodic(period_);
}
void Counter::MainCalc() {
  ++count_;
  out_.write(static_cast<double>(count_));
  if (limit_ > 0 && count_ >= limit_) Done(static_cast<double>(count_));
}

// --- Crash ---
Manifest Crash::Describe() {
  return {"Crash", "dies by SIGSEGV or abort() at its ticks-th tick (fault tests)", {scalar_port("In")}, {},
          {required("ticks", "integer", "the tick it dies at"),
           optional("how", "string", "segv", "segv or abort"),
           optional("period", "number", "0.001", "seconds between ticks")}};
}
Crash::Crash(const ControllerContext& ctx)
    : Controller(ctx), ticks_(integer("ticks")), period_(positive(number("period"), "Crash period")) {
  const auto how = text("how");
  if (how != "segv" && how != "abort")
    throw std::invalid_argument("Crash " + name() + ": how must be segv or abort, got '" + how + "'");
  abort_ = how == "abort";
}
void Crash::Run(const msgpack::object&) {
  seen_ = 0;
  StartPeriodic(period_);
}
void Crash::MainCalc() {
  if (++seen_ < ticks_) return;
  if (abort_) std::abort();
  std::signal(SIGSEGV, SIG_DFL);  // die by the signal even under a sanitizer's handler
  std::raise(SIGSEGV);
}

DCA_REGISTER_CONTROLLER(Timer);
DCA_REGISTER_CONTROLLER(Deadline);
DCA_REGISTER_CONTROLLER(Constant);
DCA_REGISTER_CONTROLLER(Gain);
DCA_REGISTER_CONTROLLER(Sum);
DCA_REGISTER_CONTROLLER(Threshold);
DCA_REGISTER_CONTROLLER(Counter);
DCA_REGISTER_CONTROLLER(Crash);

}  // namespace dca::builtins
