// The cost of a controller's port read (BENCHMARKS.md format): MainCalc of the example package's Pid
// (examples/controller_package/pid.cpp, compiled in: one In<double>::read and one Out<double>::write a tick)
// against a baseline measured in the same run, the same Pid written the old way on the node's ports
// (Input::take_latest, has_current and scalar: three calls; Output::write). Both are called through the
// controller's virtual MainCalc, in alternated batches of 1,000 calls, with a new sample delivered before each
// call (every tick reads a new sample) or none (every tick reads the old one).
//   RESULT bench=port_read variant=<new|old>_<fresh|stale> n=<batches> p50_us=.. (per call) ... p50_ns=..
// Usage: bench_port_read [BATCHES]   (default 2000)
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <dca/registry.h>

#include "controllers/controller_access.h"
#include "host/port.h"
#include "tests/bench/bench_util.h"

namespace {

// The example Pid as it was written before In<T>: its reads and writes on the node's Input and Output.
const dca::InSpec<double> kMeasured{.name = "Measured"};
const dca::OutSpec<double> kCommand{.name = "Command", .actuator = true};
const dca::Param<double> kSetpoint{.name = "setpoint"};
const dca::Param<double> kKp{.name = "kp"};

class OldPid final : public dca::PeriodicController {
  DCA_CONTROLLER(OldPid)
  void MainCalc() override {
    measured_.take_latest();
    const double y = measured_.has_current() ? measured_.scalar() : 0.0;
    const double e = setpoint_ - y, dt = period();
    integral_ += e * dt;
    const double de = first_ ? 0.0 : (e - previous_) / dt;
    previous_ = e;
    first_ = false;
    command_.write(kp_ * e + ki_ * integral_ + kd_ * de);
  }

  dca::Input& measured_;
  dca::Output& command_;
  double setpoint_, kp_, ki_ = 0.1, kd_ = 0.01;
  double integral_ = 0, previous_ = 0;
  bool first_ = true;
};
dca::Manifest OldPid::Describe() {
  return {.type = "BenchOldPid", .inputs = {kMeasured}, .outputs = {kCommand},
          .params = {kSetpoint, kKp, PeriodParam()}};
}
OldPid::OldPid(const dca::ControllerContext& ctx)
    : PeriodicController(ctx), measured_(*ports().find_input("Measured")), command_(*ports().find_output("Command")),
      setpoint_(param(kSetpoint)), kp_(param(kKp)) {}
DCA_REGISTER_CONTROLLER(OldPid);

constexpr int kCalls = 1000;

// One batch: kCalls MainCalls (each after a new sample when `fresh`); microseconds per call.
double batch(dca::Controller& c, bool fresh) {
  dca::Input& in = *c.ports().find_input("Measured");
  double v = 1.0;
  const auto t0 = std::chrono::steady_clock::now();
  for (int i = 0; i < kCalls; ++i) {
    if (fresh) {
      v += 0.001;
      in.deliver({reinterpret_cast<const std::byte*>(&v), sizeof v});
    }
    dca::ControllerAccess::main_calc(c);
  }
  const auto t1 = std::chrono::steady_clock::now();
  return std::chrono::duration<double, std::micro>(t1 - t0).count() / kCalls;
}

}  // namespace

int main(int argc, char** argv) {
  const int batches = argc > 1 ? std::max(10, std::atoi(argv[1])) : 2000;
  auto& reg = dca::Registry::global();
  auto now = reg.create("Pid", {"/new", "local", {"25", "0.5", "0.1", "0.01"}, nullptr, nullptr});
  auto old = reg.create("BenchOldPid", {"/old", "local", {"25", "0.5"}, nullptr, nullptr});
  for (bool fresh : {true, false}) {
    std::vector<double> a, b;
    for (int i = 0; i < batches; ++i) {  // alternated: A B A B
      a.push_back(batch(*now, fresh));
      b.push_back(batch(*old, fresh));
    }
    dca::bench::result_ns("port_read", fresh ? "new_fresh" : "new_stale", a);
    dca::bench::result_ns("port_read", fresh ? "old_fresh" : "old_stale", b);
  }
  return 0;
}
