#include "controllers/robot/drives.h"

#include "controllers/registry.h"

namespace dca::robot {

Manifest XR4000Ctrl::Describe() {
  return {"XR4000Ctrl", "the base's velocity drive (Nomad XR4000)",
          {vector_port("Vel", 3, "m/s, m/s, rad/s")},
          {device(vector_port("Cmd", 3, "m/s, m/s, rad/s"), "base.cmd_vel")},
          {PeriodParam(), HoldParam()},
          Ending::Never()};
}
XR4000Ctrl::XR4000Ctrl(const ControllerContext& ctx) : Drive(ctx) {}

Manifest Puma560Ctrl::Describe() {
  return {"Puma560Ctrl", "the arm's joint-velocity drive (Puma 560); also publishes the joint angles",
          {vector_port("Vel", 6, "rad/s"), device(JointsPort("Q"), "arm.q")},
          {device(vector_port("Cmd", 6, "rad/s"), "arm.cmd_qd"), JointsPort()},
          {PeriodParam(), HoldParam()},
          Ending::Never()};
}
Puma560Ctrl::Puma560Ctrl(const ControllerContext& ctx) : Drive(ctx), q_in_(input("Q")), joints_(output("Joints")) {}
void Puma560Ctrl::MainCalc() {
  if (fresh(q_in_, q_)) joints_.write(q_);
  Drive::MainCalc();
}

DCA_REGISTER_CONTROLLER(XR4000Ctrl);
DCA_REGISTER_CONTROLLER(Puma560Ctrl);

}  // namespace dca::robot
