#pragma once
// The built-in controllers: timeouts (SEMANTICS.md §12) and small real controllers for tests and systems.
// Parameters are the .dca arguments after the host, in this order. "period 0" means event-driven: MainCalc runs
// on each sample arriving at the trigger input(s).
//
// Timer(host, seconds)               no ports. DONE("timeout") `seconds` after each run; stops counting when stopped.
// Deadline(host, seconds)            no ports. ABORTED("deadline of S s passed") `seconds` after each run.
// Constant(host, period, values...)  out Out: vectorx[len(values)], units of the values.
//                                    Writes the values at each tick (period 0: once, at run).
// Gain(host, k, period=0)            in In: vectorx; out Out: vectorx, Out = k * In (same size).
//                                    Event-driven on In by default.
// Sum(host, period=0)                in In1, In2: vectorx (same size); out Out: vectorx = In1 + In2.
//                                    Event-driven on either input by default; ABORTED on a size mismatch.
// Threshold(host, level, direction=rising)
//                                    in In: scalar. DONE(the value) when In crosses `level` (rising: from below to
//                                    >= level; falling: from above to <= level; either). Event-driven on In.
// Counter(host, period, limit=0)     out Count: scalar, 1, 2, 3, ... one per tick; DONE(count) at `limit` (0: never).
// Crash(host, ticks, how=segv, period=0.001)
//                                    in In: scalar (a sink, unused). Dies by SIGSEGV (how=segv) or abort()
//                                    (how=abort) at its `ticks`-th tick: for fault tests.
#include <cstdint>
#include <string>

#include <Eigen/Core>

#include "controllers/controller.h"

namespace dca::builtins {

/// DONE("timeout") after `seconds` (SEMANTICS.md §12).
class Timer : public Controller {
 public:
  static Manifest Describe();
  explicit Timer(const ControllerContext& ctx);

 protected:
  void Run(const msgpack::object& init) override;
  void MainCalc() override;

 private:
  double seconds_;
};

/// ABORTED after `seconds` (SEMANTICS.md §12, a timeout that counts as failure).
class Deadline : public Controller {
 public:
  static Manifest Describe();
  explicit Deadline(const ControllerContext& ctx);

 protected:
  void Run(const msgpack::object& init) override;
  void MainCalc() override;

 private:
  double seconds_;
  std::string reason_;
};

/// Writes constant values.
class Constant : public Controller {
 public:
  static Manifest Describe();
  explicit Constant(const ControllerContext& ctx);

 protected:
  void Run(const msgpack::object& init) override;
  void MainCalc() override;

 private:
  Output& out_;
  double period_;
  Eigen::VectorXd values_;
};

/// Out = k * In.
class Gain : public Controller {
 public:
  static Manifest Describe();
  explicit Gain(const ControllerContext& ctx);

 protected:
  void Run(const msgpack::object& init) override;
  void MainCalc() override;

 private:
  Input& in_;
  Output& out_;
  double k_, period_;
  Eigen::VectorXd y_;
};

/// Out = In1 + In2.
class Sum : public Controller {
 public:
  static Manifest Describe();
  explicit Sum(const ControllerContext& ctx);

 protected:
  void Run(const msgpack::object& init) override;
  void MainCalc() override;

 private:
  Input& in1_;
  Input& in2_;
  Output& out_;
  double period_;
  Eigen::VectorXd y_;
};

/// DONE(value) when In crosses a level.
class Threshold : public Controller {
 public:
  static Manifest Describe();
  explicit Threshold(const ControllerContext& ctx);

 protected:
  void Run(const msgpack::object& init) override;
  void MainCalc() override;

 private:
  Input& in_;
  double level_;
  int direction_;  // +1 rising, -1 falling, 0 either
  bool have_previous_ = false;
  double previous_ = 0;
};

/// Counts ticks.
class Counter : public Controller {
 public:
  static Manifest Describe();
  explicit Counter(const ControllerContext& ctx);

 protected:
  void Run(const msgpack::object& init) override;
  void MainCalc() override;

 private:
  Output& out_;
  double period_;
  std::int64_t limit_, count_ = 0;
};

/// Dies by a signal after some ticks (fault tests).
class Crash : public Controller {
 public:
  static Manifest Describe();
  explicit Crash(const ControllerContext& ctx);

 protected:
  void Run(const msgpack::object& init) override;
  void MainCalc() override;

 private:
  std::int64_t ticks_, seen_ = 0;
  bool abort_;
  double period_;
};

}  // namespace dca::builtins
