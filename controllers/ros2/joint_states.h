#pragma once
// The process type JointStates (docs/ros2.md, "The example"): the joints of a URDF world as one
// sensor_msgs/msg/JointState, what ROS 2's joint_state_broadcaster publishes on /joint_states. The joints are
// named by the argument `joints` (spaces or commas between, at most kMaxStateJoints); slot i reads two device
// ports named after the i-th word, as joint_control's controllers do (docs/robots.md):
//   in  Q<i>    vector[1] device joint.{joints[i]}.position
//   in  Qd<i>   vector[1] device joint.{joints[i]}.velocity
//   out JointState  sensor_msgs/msg/JointState: the names, positions and velocities, stamped with the clock's
//                   time (simulated or wall), header.frame_id the argument `frame` ("" by default, as ROS has it)
// It writes once every joint's position has had a sample, every period.
#include <string>
#include <vector>

#include <Eigen/Core>

#include <dca/controller.h>
#include <dca/msgs.h>

namespace dca::ros2 {

/// The most joints one JointStates reads.
inline constexpr int kMaxStateJoints = 8;

class JointStates final : public PeriodicController {
  DCA_CONTROLLER(JointStates)

 private:
  void on_start(const msgpack::object& init) override;
  void MainCalc() override;

  using Vec1 = Eigen::Matrix<double, 1, 1>;
  std::vector<In<Vec1>> q_, qd_;
  Out<msgs::JointState> out_;
  msgs::JointState msg_;
  std::vector<char> have_;
  Vec1 sample_ = Vec1::Zero();
};

}  // namespace dca::ros2
