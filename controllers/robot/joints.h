#pragma once
// Controllers of one joint of a URDF world (docs/robots.md). Their device signals are named after the `joint`
// argument ("joint.{joint}.position"): the supervisor puts the leaf's argument in the braces when it wires them.
#include "controllers/robot/signals.h"

namespace dca::robot {

/// JointSetpoint(host, joint, target, tolerance=0.01, interface="position", gain=2, timeout=30, period=0.01):
/// drives joint `joint` to `target` (rad, or m for a prismatic joint) and ends DONE with the joint's position
/// once it is within `tolerance` of the target and slower than `tolerance` per second, on two ticks in a row;
/// ABORTED after `timeout` s. Through the position command (the target, each tick) or the velocity command
/// (gain * error, in 1/s). Stop() leaves a position command as it is (the world holds it) and writes a zero
/// velocity.
///   in  Q    vector[1] device joint.{joint}.position
///   in  Qd   vector[1] device joint.{joint}.velocity
///   out Cmd  vector[1] device joint.{joint}.{interface}_command
class JointSetpoint final : public PeriodicController {
  DCA_CONTROLLER(JointSetpoint)
  void Init() override;
  void MainCalc() override;
  void Stop() override;

  Input& q_in_;
  Input& qd_in_;
  Output& cmd_;
  double target_, tolerance_, gain_, timeout_;
  bool velocity_ = false, have_q_ = false;
  int near_ = 0;
  Eigen::Matrix<double, 1, 1> q_, qd_, cmd_value_;
};

}  // namespace dca::robot
