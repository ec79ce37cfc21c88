#pragma once
// The gripper.
#include <dca/robot/signals.h>

namespace dca::robot {

/// GripperControl(host, "open"|"close", timeout=3, period=0.01): opens or closes the gripper; DONE when it
/// is open, or when it holds something ("close"); ABORTED when it closed on nothing or the timeout passed.
///   in  State  vector[1] device gripper.state (0 open, 1 closed on nothing, 2 moving, 3 grasping)
///   out Cmd    vector[1] device gripper.cmd (0 open, 1 close)
class GripperControl final : public PeriodicController {
  DCA_CONTROLLER(GripperControl)
  void on_start(const msgpack::object& init) override;
  void MainCalc() override;

  In<Eigen::Matrix<double, 1, 1>> state_in_;
  Out<Eigen::Matrix<double, 1, 1>> cmd_;
  Eigen::Matrix<double, 1, 1> state_ = Eigen::Matrix<double, 1, 1>::Zero();
  double timeout_;
  bool close_ = false, seen_moving_ = false;
  Eigen::Matrix<double, 1, 1> cmd_value_;
};

}  // namespace dca::robot
