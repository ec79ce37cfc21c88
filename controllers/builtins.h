#pragma once
// The built-in controllers: timeouts (SEMANTICS.md §12) and small real controllers for tests and systems.
// Parameters are the .dca arguments after the host, in this order. "period 0" means event-driven: MainCalc runs
// on each sample arriving at the trigger input(s).
//
// Timer(host, seconds)               no ports. DONE("timeout") `seconds` after each run; stops counting when stopped.
// Deadline(host, seconds)            no ports. ABORTED("deadline of S s passed") `seconds` after each run.
// Constant(host, period, values...)  out Out: vectorx[len(values)], units of the values.
//                                    Writes the values at each tick (period 0: once, at run).
// Gain(host, k, period=0)            in In: vectorx; out Out: vectorx, Out = k * In (same size); k is live.
//                                    Event-driven on In by default.
// Sum(host, period=0)                in In1, In2: vectorx (same size); out Out: vectorx = In1 + In2.
//                                    Event-driven on either input by default; ABORTED on a size mismatch.
//                                    Constant, Gain and Sum feed and are fed by scalar and vector[n] ports too:
//                                    a vectorx end takes the other end's size (docs/lua.md, "Port types").
// Threshold(host, level, direction=rising)
//                                    in In: scalar. DONE(the value) when In crosses `level` (rising: from below to
//                                    >= level; falling: from above to <= level; either). Event-driven on In.
// Counter(host, period, limit=0)     out Count: scalar, 1, 2, 3, ... one per tick; DONE(count) at `limit` (0: never).
// Crash(host, ticks, how=segv, period=0.001)
//                                    in In: scalar (a sink, unused). Dies by SIGSEGV (how=segv) or abort()
//                                    (how=abort) at its `ticks`-th tick: for fault tests.
#include <cstdint>
#include <string>
#include <string_view>

#include <Eigen/Core>

#include <dca/controller.h>

namespace dca::builtins {

/// A one-shot timeout (SEMANTICS.md §12): `seconds` after each run, Timer ends DONE("timeout") and Deadline
/// (kAborts) ends ABORTED("deadline of S s passed").
template <bool kAborts>
class Timeout final : public Controller {
  DCA_CONTROLLER(Timeout)
  void on_start(const msgpack::object&) override { StartOneShot(seconds_); }
  void MainCalc() override;

  double seconds_;
};
using Timer = Timeout<false>;
using Deadline = Timeout<true>;
template <>
Manifest Timer::Describe();
template <>
Manifest Deadline::Describe();
template <>
void Timer::MainCalc();
template <>
void Deadline::MainCalc();

/// Writes constant values (event-driven: once, at run).
class Constant final : public PeriodicController {
  DCA_CONTROLLER(Constant)
  void MainCalc() override { out_.write(values_); }

  Out<Eigen::VectorXd> out_;
  Eigen::VectorXd values_;
};

/// Out = k * In.
class Gain final : public PeriodicController {
  DCA_CONTROLLER(Gain)
  void MainCalc() override;
  std::string on_parameter(std::string_view name) override;  // k is live

  In<Eigen::VectorXd> in_;
  Out<Eigen::VectorXd> out_;
  double k_;
  Eigen::VectorXd x_, y_;
};

/// Out = In1 + In2.
class Sum final : public PeriodicController {
  DCA_CONTROLLER(Sum)
  void MainCalc() override;

  In<Eigen::VectorXd> in1_, in2_;
  Out<Eigen::VectorXd> out_;
  Eigen::VectorXd a_, b_, y_;
};

/// DONE(value) when In crosses a level.
class Threshold final : public Controller {
  DCA_CONTROLLER(Threshold)
  void on_start(const msgpack::object& init) override;
  void MainCalc() override;

  In<double> in_;
  double level_, previous_ = 0;
  int direction_;  // +1 rising, -1 falling, 0 either
  bool have_previous_ = false;
};

/// Counts ticks.
class Counter final : public PeriodicController {
  DCA_CONTROLLER(Counter)
  void on_configure() override { count_ = 0; }
  void MainCalc() override;

  Out<double> out_;
  std::int64_t limit_, count_ = 0;
};

/// Dies by a signal after some ticks (fault tests).
class Crash final : public PeriodicController {
  DCA_CONTROLLER(Crash)
  void on_configure() override { seen_ = 0; }
  void MainCalc() override;

  enum class How { Segv, Abort, Hang };
  std::int64_t ticks_, seen_ = 0;
  How how_ = How::Segv;
};

}  // namespace dca::builtins
