// Pid(host, setpoint, kp, ki=0, kd=0, period=0.01): a PID controller on a scalar.
//   in  Measured  scalar   the measured value (0 until the first sample)
//   out Command   scalar   kp e + ki (integral of e) + kd de/dt, e = setpoint - Measured; zero when halted
#include <dca/controller.h>
#include <dca/registry.h>

namespace mylab {

// Each port and parameter is declared once: the manifest lists these, the constructor binds them.
const dca::InSpec<double> kMeasured{.name = "Measured"};
const dca::OutSpec<double> kCommand{.name = "Command", .actuator = true};  // written zero by halt()
const dca::Param<double> kSetpoint{.name = "setpoint", .doc = "the value Measured should reach"};
const dca::Param<double> kKp{.name = "kp", .doc = "proportional gain", .min = 0};
const dca::Param<double> kKi{.name = "ki", .doc = "integral gain (1/s)", .def = 0, .min = 0};
const dca::Param<double> kKd{.name = "kd", .doc = "derivative gain (s)", .def = 0, .min = 0};

class Pid final : public dca::PeriodicController {
  DCA_CONTROLLER(Pid)
  void on_configure() override;
  void MainCalc() override;

  dca::In<double> measured_;
  dca::Out<double> command_;
  double setpoint_, kp_, ki_, kd_;
  double y_ = 0, integral_ = 0, previous_ = 0;
  bool first_ = true;
};

dca::Manifest Pid::Describe() {
  return {.type = "Pid",
          .doc = "a PID controller: Command = kp e + ki int(e) + kd de/dt, e = setpoint - Measured",
          .inputs = {kMeasured},
          .outputs = {kCommand},
          .params = {kSetpoint, kKp, kKi, kKd, PeriodParam(0.01)},
          .ends = dca::Ending::Never()};  // how a run ends by itself: a controller runs until halted
}

Pid::Pid(const dca::ControllerContext& ctx)
    : PeriodicController(ctx), measured_(port(kMeasured)), command_(port(kCommand)), setpoint_(param(kSetpoint)),
      kp_(param(kKp)), ki_(param(kKi)), kd_(param(kKd)) {}

void Pid::on_configure() {
  y_ = 0;
  integral_ = 0;
  previous_ = 0;
  first_ = true;
}

void Pid::MainCalc() {
  measured_.read(y_);  // New or Old: y_ is the newest sample; None: y_ stays 0
  const double e = setpoint_ - y_, dt = period();
  integral_ += e * dt;
  const double de = first_ ? 0.0 : (e - previous_) / dt;
  previous_ = e;
  first_ = false;
  command_.write(kp_ * e + ki_ * integral_ + kd_ * de);
}

DCA_REGISTER_CONTROLLER(Pid);

}  // namespace mylab
