#pragma once
// A mobile base to and from ROS 2's messages (docs/ros2.md, "The examples"):
//   BaseTwist(host, timeout=0.5, period=0.01)
//     in  Twist  geometry_msgs/msg/Twist (a trigger: what a bridge's sub row of /cmd_vel writes)
//     out Vel    vector[3] (vx, vy in m/s, yaw rate in rad/s: linear.x, linear.y, angular.z), an actuator; the
//                last Twist every period until `timeout` s after it arrived, then zero (a deadman, as ROS's
//                base drivers have)
//   BaseOdometry(host, frame="odom", child="base_link", period=0.02)
//     in  Pose      vector[3] (x, y in m, yaw in rad: XR4000Odometry's Pose)
//     out Odometry  nav_msgs/msg/Odometry: the pose (yaw as a quaternion about z) and the twist in the base's
//                   frame from the last two poses, stamped with the clock's time
//     out Tf        tf2_msgs/msg/TFMessage: the same pose as the one transform frame -> child (for /tf)
#include <Eigen/Core>

#include <dca/controller.h>
#include <dca/msgs.h>

namespace dca::ros2 {

class BaseTwist final : public PeriodicController {
  DCA_CONTROLLER(BaseTwist)

 private:
  void on_start(const msgpack::object& init) override;
  void MainCalc() override;

  In<msgs::Twist> in_;
  Out<Eigen::Vector3d> out_;
  Nanos timeout_;
  Nanos last_ = 0;
  bool have_ = false;
  msgs::Twist twist_;
};

class BaseOdometry final : public PeriodicController {
  DCA_CONTROLLER(BaseOdometry)

 private:
  void on_start(const msgpack::object& init) override;
  void MainCalc() override;

  In<Eigen::Vector3d> in_;
  Out<msgs::Odometry> out_;
  Out<msgs::TFMessage> tf_out_;
  msgs::Odometry msg_;
  msgs::TFMessage tf_;
  Eigen::Vector3d pose_ = Eigen::Vector3d::Zero(), last_pose_ = Eigen::Vector3d::Zero();
  Nanos last_time_ = 0;
  bool have_ = false;
};

}  // namespace dca::ros2
