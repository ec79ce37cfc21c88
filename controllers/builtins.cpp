#include "controllers/builtins.h"

#include <unistd.h>

#include <csignal>
#include <cstdlib>

#include "controllers/registry.h"

namespace dca::builtins {

using P = ParamSpec;

// --- Timer, Deadline ---
template <>
Manifest Timer::Describe() {
  return {"Timer", "ends DONE with value \"timeout\" `seconds` after each start (SEMANTICS.md 12)", {}, {},
          {P::Required("seconds", "number", "the timeout, in seconds")},
          Ending::DoneAfter("seconds")};
}
template <>
Manifest Deadline::Describe() {
  return {"Deadline", "ends ABORTED `seconds` after each start (a timeout that counts as failure)", {}, {},
          {P::Required("seconds", "number", "the deadline, in seconds")},
          Ending::AbortedAfter("seconds")};
}
template <bool kAborts>
Timeout<kAborts>::Timeout(const ControllerContext& ctx) : Controller(ctx), seconds_(non_negative("seconds")) {}
template <>
void Timer::MainCalc() {
  Done(std::string_view("timeout"));
}
template <>
void Deadline::MainCalc() {
  Abort("deadline of " + text("seconds") + " s passed");
}
template class Timeout<false>;
template class Timeout<true>;

// --- Constant ---
Manifest Constant::Describe() {
  return {"Constant", "writes constant values on Out every period (period 0: once, at start)", {},
          {vectorx_port("Out")},
          {P::Required("period", "number", "seconds between writes; 0 writes once at start"),
           P::Variadic("values", "number", "the values written (Out has as many elements)")},
          Ending::Never()};
}
Constant::Constant(const ControllerContext& ctx)
    : PeriodicController(ctx, Period::ZeroIsEventDriven), out_(output("Out")) {
  const auto v = numbers("values");
  values_ = Eigen::Map<const Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size()));
}

// --- Gain ---
Manifest Gain::Describe() {
  return {"Gain", "Out = k * In, on each In sample (or every period)", {vectorx_port("In")}, {vectorx_port("Out")},
          {P::Required("k", "number", "the gain"),
           PeriodParam("0", "seconds between computations; 0: on each In sample")},
          Ending::Never()};
}
Gain::Gain(const ControllerContext& ctx)
    : PeriodicController(ctx, Period::ZeroIsEventDriven), in_(trigger("In")), out_(output("Out")), k_(number("k")) {
  y_.resize(64);  // grown (outside MainCalc's steady state) only for bigger samples
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
          {PeriodParam("0", "seconds between computations; 0: on each sample")},
          Ending::Aborted()};
}
Sum::Sum(const ControllerContext& ctx)
    : PeriodicController(ctx, Period::ZeroIsEventDriven), in1_(trigger("In1")), in2_(trigger("In2")),
      out_(output("Out")) {
  y_.resize(64);
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
          {P::Required("level", "number", "the level"),
           P::Optional("direction", "string", "rising", "rising, falling or either")},
          Ending::Done()};
}
Threshold::Threshold(const ControllerContext& ctx) : Controller(ctx), in_(input("In")), level_(number("level")) {
  const auto d = text("direction");
  if (d == "rising") direction_ = 1;
  else if (d == "falling") direction_ = -1;
  else if (d == "either") direction_ = 0;
  else throw bad_param("direction must be rising, falling or either, got '" + d + "'");
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
          {P::Required("period", "number", "seconds between ticks"),
           P::Optional("limit", "integer", "0", "DONE when the count reaches it; 0: never")},
          Ending::Done()};
}
Counter::Counter(const ControllerContext& ctx)
    : PeriodicController(ctx), out_(output("Count")), limit_(integer("limit")) {}
void Counter::MainCalc() {
  ++count_;
  out_.write(static_cast<double>(count_));
  if (limit_ > 0 && count_ >= limit_) Done(static_cast<double>(count_));
}

// --- Crash ---
Manifest Crash::Describe() {
  return {"Crash", "dies by SIGSEGV or abort() at its ticks-th tick, or hangs there until killed (fault tests)",
          {scalar_port("In")}, {},
          {P::Required("ticks", "integer", "the tick it dies (or hangs) at"),
           P::Optional("how", "string", "segv", "segv, abort or hang (blocks in MainCalc until a signal ends it)"),
           PeriodParam("0.001")},
          Ending::Aborted()};
}
Crash::Crash(const ControllerContext& ctx) : PeriodicController(ctx), ticks_(integer("ticks")) {
  const auto how = text("how");
  if (how == "abort") how_ = How::Abort;
  else if (how == "hang") how_ = How::Hang;
  else if (how != "segv") throw bad_param("how must be segv, abort or hang, got '" + how + "'");
}
void Crash::MainCalc() {
  if (++seen_ < ticks_) return;
  if (how_ == How::Abort) std::abort();
  if (how_ == How::Hang) {
    for (;;) ::pause();  // its code runs (the crash note names it) until a signal from outside ends the process
  }
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
