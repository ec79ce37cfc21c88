// Pid(host, setpoint, kp, ki=0, kd=0, period=0.01): a PID controller on a scalar.
//   in  Measured  scalar   the measured value (0 until the first sample)
//   out Command   scalar   kp e + ki (integral of e) + kd de/dt, e = setpoint - Measured; zero when stopped
#include "controllers/controller.h"
#include "controllers/registry.h"

namespace mylab {

class Pid final : public dca::PeriodicController {
  DCA_CONTROLLER(Pid)
  void Init() override;
  void MainCalc() override;

  dca::Input& measured_;
  dca::Output& command_;
  double setpoint_, kp_, ki_, kd_;
  double integral_ = 0, previous_ = 0;
  bool first_ = true;
};

dca::Manifest Pid::Describe() {
  using P = dca::ParamSpec;
  return {"Pid", "a PID controller: Command = kp e + ki int(e) + kd de/dt, e = setpoint - Measured",
          {dca::scalar_port("Measured")},
          {dca::scalar_port("Command")},
          {P::Required("setpoint", "number", "the value Measured should reach"),
           P::Required("kp", "number", "proportional gain"), P::Number("ki", "0", "integral gain (1/s)"),
           P::Number("kd", "0", "derivative gain (s)"), PeriodParam("0.01")},
          dca::Ending::Never()};  // how a run ends by itself: a controller runs until stopped
}

Pid::Pid(const dca::ControllerContext& ctx)
    : PeriodicController(ctx), measured_(input("Measured")), command_(actuator("Command")),
      setpoint_(number("setpoint")), kp_(number("kp")), ki_(number("ki")), kd_(number("kd")) {}

void Pid::Init() {
  integral_ = 0;
  previous_ = 0;
  first_ = true;
}

void Pid::MainCalc() {
  measured_.take_latest();
  const double y = measured_.has_current() ? measured_.scalar() : 0.0;
  const double e = setpoint_ - y, dt = period();
  integral_ += e * dt;
  const double de = first_ ? 0.0 : (e - previous_) / dt;
  previous_ = e;
  first_ = false;
  command_.write(kp_ * e + ki_ * integral_ + kd_ * de);
}

DCA_REGISTER_CONTROLLER(Pid);

}  // namespace mylab
