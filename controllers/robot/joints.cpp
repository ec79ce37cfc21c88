#include "controllers/robot/joints.h"

#include <cmath>

#include <dca/registry.h>

namespace dca::robot {

namespace {
using Vec1 = Eigen::Matrix<double, 1, 1>;
const InSpec<Vec1> kJointQ{.name = "Q", .units = "rad or m", .device = "joint.{joint}.position"};
const InSpec<Vec1> kJointQd{.name = "Qd", .units = "rad/s or m/s", .device = "joint.{joint}.velocity"};
// (no actuator: halt()'s zero would be a position; on_halt zeroes a velocity command itself)
const OutSpec<Vec1> kJointCmd{.name = "Cmd", .units = "rad or m, or rad/s or m/s",
                              .device = "joint.{joint}.{interface}_command"};
const Param<std::string> kJoint{.name = "joint", .doc = "the joint's name in the URDF"};
const Param<double> kTarget{.name = "target", .doc = "the position to reach (rad or m)"};
const Param<double> kTolerance{
    .name = "tolerance", .doc = "DONE within this of the target, and slower than it per second", .def = 0.01, .above = 0};
const Param<std::string> kInterface{
    .name = "interface", .doc = "the command interface", .def = "position", .allowed = {"position", "velocity"}};
const Param<double> kGain{.name = "gain", .doc = "velocity interface: the command is gain * error (1/s)", .def = 2,
                          .above = 0};
const Param<double> kJointTimeout{.name = "timeout", .doc = "ABORTED when not there after this many seconds",
                                  .def = 30, .above = 0};
}  // namespace

Manifest JointSetpoint::Describe() {
  return {.type = "JointSetpoint", .doc = "drives one joint of a URDF world to a target; DONE(position) when there",
          .inputs = {kJointQ, kJointQd}, .outputs = {kJointCmd},
          .params = {kJoint, kTarget, kTolerance, kInterface, kGain, kJointTimeout, PeriodParam()},
          .ends = Ending::DoneOrAborted()};
}

JointSetpoint::JointSetpoint(const ControllerContext& ctx)
    : PeriodicController(ctx), q_in_(port(kJointQ)), qd_in_(port(kJointQd)), cmd_(port(kJointCmd)),
      target_(param(kTarget)), tolerance_(param(kTolerance)), gain_(param(kGain)), timeout_(param(kJointTimeout)),
      velocity_(param(kInterface) == "velocity") {}

void JointSetpoint::on_configure() {
  have_q_ = false;
  near_ = 0;
  qd_.setZero();
}

void JointSetpoint::MainCalc() {
  if (q_in_.read(q_) == Read::New) have_q_ = true;
  qd_in_.read(qd_);
  if (!have_q_) return;
  const double error = target_ - q_[0];
  cmd_value_[0] = velocity_ ? gain_ * error : target_;
  cmd_.write(cmd_value_);
  near_ = std::abs(error) <= tolerance_ && std::abs(qd_[0]) <= tolerance_ ? near_ + 1 : 0;
  if (near_ >= 2) return Done(q_[0]);
  if (to_seconds(now() - started()) > timeout_)
    Abort("joint " + param(kJoint) + " did not reach " + text(kTarget) + " within " + text(kJointTimeout) + " s");
}

void JointSetpoint::on_halt() {
  if (!velocity_) return;
  cmd_value_.setZero();
  cmd_.write(cmd_value_);
}

DCA_REGISTER_CONTROLLER(JointSetpoint);

namespace {
const OutSpec<Vec1> kPress{.name = "Press", .units = "1: pressed", .device = "estop"};
const Param<double> kAt{.name = "at", .doc = "s after its start: the press", .min = 0};
const Param<double> kHold{.name = "hold", .doc = "s it stays pressed (at least one tick)", .def = 0, .min = 0};
}  // namespace

Manifest EStopButton::Describe() {
  return {.type = "EStopButton", .doc = "presses the robot's emergency stop at a time; DONE(time) once let go",
          .inputs = {}, .outputs = {kPress}, .params = {kAt, kHold, PeriodParam()}, .ends = Ending::Done()};
}

EStopButton::EStopButton(const ControllerContext& ctx)
    : PeriodicController(ctx), press_(port(kPress)), at_(param(kAt)), hold_(param(kHold)) {}

void EStopButton::on_configure() { pressed_at_ = -1; }

void EStopButton::MainCalc() {
  const double t = to_seconds(now() - started());
  const bool first = pressed_at_ < 0 && t >= at_ - 1e-9;
  if (first) pressed_at_ = t;
  const bool held = first || (pressed_at_ >= 0 && t < pressed_at_ + hold_ - 1e-9);
  press_.write(Vec1::Constant(held ? 1.0 : 0.0));
  if (pressed_at_ >= 0 && !held) Done(pressed_at_);
}

DCA_REGISTER_CONTROLLER(EStopButton);

}  // namespace dca::robot
