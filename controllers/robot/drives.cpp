#include "controllers/robot/drives.h"

#include <dca/registry.h>

namespace dca::robot {

namespace {
const InSpec<Vec3> kBaseVel{.name = "Vel", .units = "m/s, m/s, rad/s"};
const OutSpec<Vec3> kBaseCmd{.name = "Cmd", .units = "m/s, m/s, rad/s", .device = "base.cmd_vel", .actuator = true};
const InSpec<Vec6> kArmVel{.name = "Vel", .units = "rad/s"};
const InSpec<Vec6> kQ = device(JointsIn("Q"), "arm.q");
const OutSpec<Vec6> kArmCmd{.name = "Cmd", .units = "rad/s", .device = "arm.cmd_qd", .actuator = true};
const OutSpec<Vec6> kJoints = JointsOut();
}  // namespace

Manifest XR4000Ctrl::Describe() {
  return {.type = "XR4000Ctrl", .doc = "the base's velocity drive (Nomad XR4000)", .inputs = {kBaseVel},
          .outputs = {kBaseCmd}, .params = {PeriodParam(), HoldParam()}, .ends = Ending::Never()};
}
XR4000Ctrl::XR4000Ctrl(const ControllerContext& ctx) : Drive(ctx, kBaseVel, kBaseCmd) {}

Manifest Puma560Ctrl::Describe() {
  return {.type = "Puma560Ctrl", .doc = "the arm's joint-velocity drive (Puma 560); also publishes the joint angles",
          .inputs = {kArmVel, kQ}, .outputs = {kArmCmd, kJoints}, .params = {PeriodParam(), HoldParam()},
          .ends = Ending::Never()};
}
Puma560Ctrl::Puma560Ctrl(const ControllerContext& ctx)
    : Drive(ctx, kArmVel, kArmCmd), q_in_(port(kQ)), joints_(port(kJoints)) {}
void Puma560Ctrl::MainCalc() {
  if (q_in_.read(q_) == Read::New) joints_.write(q_);
  Drive::MainCalc();
}

DCA_REGISTER_CONTROLLER(XR4000Ctrl);
DCA_REGISTER_CONTROLLER(Puma560Ctrl);

}  // namespace dca::robot
