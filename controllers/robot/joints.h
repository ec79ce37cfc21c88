#pragma once
// Controllers of one joint of a URDF world (docs/robots.md). Their device signals are named after the `joint`
// argument ("joint.{joint}.position"): the supervisor puts the leaf's argument in the braces when it wires them.
#include <dca/robot/signals.h>

namespace dca::robot {

/// JointSetpoint(host, joint, target, tolerance=0.01, interface="position", gain=2, timeout=30, period=0.01):
/// drives joint `joint` to `target` (rad, or m for a prismatic joint) and ends DONE with the joint's position
/// once it is within `tolerance` of the target and slower than `tolerance` per second, on two ticks in a row;
/// ABORTED after `timeout` s. Through the position command (the target, each tick) or the velocity command
/// (gain * error, in 1/s). halt() leaves a position command as it is (the world holds it: zero would be a
/// position, not a stop) and writes a zero velocity.
///   in  Q    vector[1] device joint.{joint}.position
///   in  Qd   vector[1] device joint.{joint}.velocity
///   out Cmd  vector[1] device joint.{joint}.{interface}_command
class JointSetpoint final : public PeriodicController {
  DCA_CONTROLLER(JointSetpoint)
  using Vec1 = Eigen::Matrix<double, 1, 1>;
  void on_configure() override;
  void MainCalc() override;
  void on_halt() override;

  In<Vec1> q_in_;
  In<Vec1> qd_in_;
  Out<Vec1> cmd_;
  double target_, tolerance_, gain_, timeout_;
  bool velocity_ = false, have_q_ = false;
  int near_ = 0;
  Vec1 q_ = Vec1::Zero(), qd_ = Vec1::Zero(), cmd_value_ = Vec1::Zero();
};

/// EStopButton(host, at, hold=0, period=0.01): the robot's emergency stop pressed by a leaf (docs/safety.md,
/// "Emergency stop"), as a button wired to the robot would: writes 0 on Press every tick before `at` s after its
/// start, 1 from then on for `hold` s (at least one tick), then 0 (the button let go: a release may follow) and
/// ends DONE with the press's time (s after its start).
///   out Press vector[1] device estop
class EStopButton final : public PeriodicController {
  DCA_CONTROLLER(EStopButton)
  using Vec1 = Eigen::Matrix<double, 1, 1>;
  void on_configure() override;
  void MainCalc() override;

  Out<Vec1> press_;
  double at_, hold_;
  double pressed_at_ = -1;
};

}  // namespace dca::robot
