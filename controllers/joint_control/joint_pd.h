#pragma once
// JointPD: a joint-space PD for any arm of a URDF world (docs/robots.md, "joint_control").
#include <string>

#include <Eigen/Core>

#include "joint_group.h"

namespace dca::joint_control {

/// JointPD(host, joints, kp, kd=0, interface="effort", period=0.01, targets...): holds the joints `joints` names
/// at a reference: u = kp (r - q) + kd (rd - qd) on the effort command (N m or N), or rd + kp (r - q) + kd (rd -
/// qd) on the velocity command. The reference r comes from the input Ref and its velocity rd from RefVel (0
/// until a sample), each one number per joint; before any Ref it is `targets` (one per joint), or where the
/// joints were at the first tick. Never ends by itself but ABORTED by a Ref or RefVel of another size. Its
/// commands are actuators: halt() writes them zero.
///   in  Q1..Q8, Qd1..Qd8, out Cmd1..Cmd8: the joints' device ports (joint_group.h)
///   in  Ref     vectorx  rad or m, per joint
///   in  RefVel  vectorx  rad/s or m/s, per joint
///   out Error   vectorx  r - q, per joint
class JointPD final : public JointGroup {
  DCA_CONTROLLER(JointPD)
  void on_configure() override;
  void MainCalc() override;
  /// Why a sample at `input` is refused: its size.
  std::string wrong_size(const char* input) const;

  In<Eigen::VectorXd> ref_in_, ref_vel_in_;
  Out<Eigen::VectorXd> error_out_;
  double kp_, kd_;
  bool velocity_ = false, have_ref_ = false;
  Eigen::VectorXd targets_, ref_, ref_vel_, input_, error_, cmd_;
};

}  // namespace dca::joint_control
