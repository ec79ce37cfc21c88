#include "controllers/builtins.h"

#include <unistd.h>

#include <csignal>
#include <cstdlib>

#include <dca/registry.h>

namespace dca::builtins {

// --- Timer, Deadline ---
namespace {
const Param<double> kTimerSeconds{.name = "seconds", .doc = "the timeout, in seconds", .min = 0};
const Param<double> kDeadlineSeconds{.name = "seconds", .doc = "the deadline, in seconds", .min = 0};
}  // namespace
template <>
Manifest Timer::Describe() {
  return {.type = "Timer", .doc = "ends DONE with value \"timeout\" `seconds` after each start (SEMANTICS.md 12)",
          .params = {kTimerSeconds}, .ends = Ending::DoneAfter("seconds")};
}
template <>
Manifest Deadline::Describe() {
  return {.type = "Deadline", .doc = "ends ABORTED `seconds` after each start (a timeout that counts as failure)",
          .params = {kDeadlineSeconds}, .ends = Ending::AbortedAfter("seconds")};
}
template <bool kAborts>
Timeout<kAborts>::Timeout(const ControllerContext& ctx)
    : Controller(ctx), seconds_(param(kAborts ? kDeadlineSeconds : kTimerSeconds)) {}
template <>
void Timer::MainCalc() {
  Done(std::string_view("timeout"));
}
template <>
void Deadline::MainCalc() {
  Abort("deadline of " + text(kDeadlineSeconds) + " s passed");
}
template class Timeout<false>;
template class Timeout<true>;

// --- Constant ---
namespace {
const OutSpec<Eigen::VectorXd> kConstantOut{.name = "Out"};
const Param<std::vector<double>> kValues{.name = "values", .doc = "the values written (Out has as many elements)"};
}  // namespace
Manifest Constant::Describe() {
  return {.type = "Constant", .doc = "writes constant values on Out every period (period 0: once, at start)",
          .outputs = {kConstantOut},
          .params = {PeriodParam(std::nullopt, "seconds between writes; 0 writes once at start",
                                 Period::ZeroIsEventDriven),
                     kValues},
          .ends = Ending::Never()};
}
Constant::Constant(const ControllerContext& ctx)
    : PeriodicController(ctx, Period::ZeroIsEventDriven), out_(port(kConstantOut)) {
  const auto v = param(kValues);
  values_ = Eigen::Map<const Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size()));
}

// --- Gain ---
namespace {
const InSpec<Eigen::VectorXd> kGainIn{.name = "In", .trigger = true};
const OutSpec<Eigen::VectorXd> kGainOut{.name = "Out"};
const Param<double> kK{.name = "k", .doc = "the gain", .live = true};
}  // namespace
Manifest Gain::Describe() {
  return {.type = "Gain", .doc = "Out = k * In, on each In sample (or every period)", .inputs = {kGainIn},
          .outputs = {kGainOut},
          .params = {kK, PeriodParam(0, "seconds between computations; 0: on each In sample",
                                     Period::ZeroIsEventDriven)},
          .ends = Ending::Never()};
}
Gain::Gain(const ControllerContext& ctx)
    : PeriodicController(ctx, Period::ZeroIsEventDriven), in_(port(kGainIn)), out_(port(kGainOut)), k_(param(kK)) {
  y_.resize(64);  // grown (outside MainCalc's steady state) only for bigger samples
}
// k changes while it runs (docs/packages.md, "Live parameters"): the next sample is scaled by the new k.
std::string Gain::on_parameter(std::string_view) {
  k_ = param(kK);
  return "";
}
void Gain::MainCalc() {
  if (in_.read(x_) == Read::None) return;
  if (y_.size() < x_.size()) y_.resize(x_.size());
  auto y = y_.head(x_.size());
  y.noalias() = k_ * x_;
  out_.write(y);
}

// --- Sum ---
namespace {
const InSpec<Eigen::VectorXd> kIn1{.name = "In1", .trigger = true};
const InSpec<Eigen::VectorXd> kIn2{.name = "In2", .trigger = true};
const OutSpec<Eigen::VectorXd> kSumOut{.name = "Out"};
}  // namespace
Manifest Sum::Describe() {
  return {.type = "Sum", .doc = "Out = In1 + In2 (same sizes), on each input sample (or every period)",
          .inputs = {kIn1, kIn2}, .outputs = {kSumOut},
          .params = {PeriodParam(0, "seconds between computations; 0: on each sample", Period::ZeroIsEventDriven)},
          .ends = Ending::Aborted()};
}
Sum::Sum(const ControllerContext& ctx)
    : PeriodicController(ctx, Period::ZeroIsEventDriven), in1_(port(kIn1)), in2_(port(kIn2)), out_(port(kSumOut)) {
  y_.resize(64);
}
void Sum::MainCalc() {
  const Read r1 = in1_.read(a_), r2 = in2_.read(b_);
  if (r1 == Read::None || r2 == Read::None) return;
  if (a_.size() != b_.size()) return Abort("Sum: In1 has " + std::to_string(a_.size()) + " values but In2 has " +
                                           std::to_string(b_.size()));
  if (y_.size() < a_.size()) y_.resize(a_.size());
  auto y = y_.head(a_.size());
  y.noalias() = a_ + b_;
  out_.write(y);
}

// --- Threshold ---
namespace {
const InSpec<double> kThresholdIn{.name = "In", .trigger = true};
const Param<double> kLevel{.name = "level", .doc = "the level"};
const Param<std::string> kDirection{.name = "direction", .doc = "rising, falling or either", .def = "rising",
                                    .allowed = {"rising", "falling", "either"}};
}  // namespace
Manifest Threshold::Describe() {
  return {.type = "Threshold", .doc = "ends DONE with the value when In crosses the level",
          .inputs = {kThresholdIn}, .params = {kLevel, kDirection}, .ends = Ending::Done()};
}
Threshold::Threshold(const ControllerContext& ctx) : Controller(ctx), in_(port(kThresholdIn)), level_(param(kLevel)) {
  const auto d = param(kDirection);
  direction_ = d == "rising" ? 1 : d == "falling" ? -1 : 0;
}
void Threshold::on_start(const msgpack::object&) { have_previous_ = false; }
void Threshold::MainCalc() {
  double v = 0;
  while (in_.pop(v)) {
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
namespace {
const OutSpec<double> kCount{.name = "Count"};
const Param<std::int64_t> kLimit{.name = "limit", .doc = "DONE when the count reaches it; 0: never", .def = 0};
}  // namespace
Manifest Counter::Describe() {
  return {.type = "Counter", .doc = "writes 1, 2, 3, ... on Count, one per tick; DONE(count) at the limit",
          .outputs = {kCount}, .params = {PeriodParam(std::nullopt), kLimit},
          .ends = Ending::Done().NeverWhen("limit", "0")};
}
Counter::Counter(const ControllerContext& ctx) : PeriodicController(ctx), out_(port(kCount)), limit_(param(kLimit)) {}
void Counter::MainCalc() {
  ++count_;
  out_.write(static_cast<double>(count_));
  if (limit_ > 0 && count_ >= limit_) Done(static_cast<double>(count_));
}

// --- Crash ---
namespace {
const InSpec<double> kCrashIn{.name = "In"};
const Param<std::int64_t> kTicks{.name = "ticks", .doc = "the tick it dies (or hangs) at"};
const Param<std::string> kHow{.name = "how", .doc = "segv, abort or hang (blocks in MainCalc until a signal ends it)",
                              .def = "segv", .allowed = {"segv", "abort", "hang"}};
}  // namespace
Manifest Crash::Describe() {
  return {.type = "Crash", .doc = "dies by SIGSEGV or abort() at its ticks-th tick, or hangs there until killed (fault tests)",
          .inputs = {kCrashIn}, .params = {kTicks, kHow, PeriodParam(0.001)}, .ends = Ending::Aborted()};
}
Crash::Crash(const ControllerContext& ctx)
    : PeriodicController(ctx), ticks_(param(kTicks)),
      how_(param(kHow) == "abort" ? How::Abort : param(kHow) == "hang" ? How::Hang : How::Segv) {}
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
