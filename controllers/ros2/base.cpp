#include "base.h"

#include <cmath>

#include <dca/registry.h>

#include "stamp.h"

namespace dca::ros2 {
namespace {

const InSpec<msgs::Twist> kTwist{.name = "Twist"};
const OutSpec<Eigen::Vector3d> kVel{.name = "Vel", .units = "m/s, m/s, rad/s", .actuator = true};
const Param<double> kTimeout{
    .name = "timeout", .doc = "seconds a Twist is obeyed for, then zero (a deadman)", .def = 0.5, .above = 0};
const InSpec<Eigen::Vector3d> kPose{.name = "Pose", .units = "m, m, rad"};
const OutSpec<msgs::Odometry> kOdometry{.name = "Odometry"};
const OutSpec<msgs::TFMessage> kOdometryTf{.name = "Tf"};
const Param<std::string> kOdometryFrame{.name = "frame", .doc = "header.frame_id: the odometry's frame", .def = "odom"};
const Param<std::string> kChild{.name = "child", .doc = "child_frame_id: the base's frame", .def = "base_link"};

}  // namespace

Manifest BaseTwist::Describe() {
  return {.type = "BaseTwist",
          .doc = "a geometry_msgs/msg/Twist (ROS 2's /cmd_vel) as a base's velocity command, with a deadman",
          .inputs = {kTwist},
          .outputs = {kVel},
          .params = {kTimeout, PeriodParam()},
          .ends = Ending::Never()};
}

BaseTwist::BaseTwist(const ControllerContext& ctx)
    : PeriodicController(ctx), in_(port(kTwist)), out_(port(kVel)), timeout_(from_seconds(param(kTimeout))) {}

void BaseTwist::on_start(const msgpack::object&) { have_ = false; }

void BaseTwist::MainCalc() {
  if (in_.read(twist_) == Read::New) {
    last_ = now();
    have_ = true;
  }
  const bool live = have_ && now() - last_ <= timeout_;
  out_.write(live ? Eigen::Vector3d(twist_.linear.x, twist_.linear.y, twist_.angular.z) : Eigen::Vector3d::Zero());
}

Manifest BaseOdometry::Describe() {
  return {.type = "BaseOdometry",
          .doc = "a base's pose (x, y, yaw) as nav_msgs/msg/Odometry (ROS 2's /odom)",
          .inputs = {kPose},
          .outputs = {kOdometry, kOdometryTf},
          .params = {kOdometryFrame, kChild, PeriodParam(0.02)},
          .ends = Ending::Never()};
}

BaseOdometry::BaseOdometry(const ControllerContext& ctx)
    : PeriodicController(ctx), in_(port(kPose)), out_(port(kOdometry)), tf_out_(port(kOdometryTf)) {
  if (!msg_.header.frame_id.assign(param(kOdometryFrame))) throw bad_param("parameter 'frame' is longer than 63 bytes");
  if (!msg_.child_frame_id.assign(param(kChild))) throw bad_param("parameter 'child' is longer than 63 bytes");
  tf_.transforms.resize(1);
  tf_.transforms[0].header.frame_id = msg_.header.frame_id;
  tf_.transforms[0].child_frame_id = msg_.child_frame_id;
}

void BaseOdometry::on_start(const msgpack::object&) { have_ = false; }

void BaseOdometry::MainCalc() {
  if (in_.read(pose_) == Read::None) return;
  const Nanos t = now();
  const double dt = to_seconds(t - last_time_);
  if (have_ && dt > 0) {  // the twist in the base's frame, from the last two poses
    const double c = std::cos(pose_(2)), s = std::sin(pose_(2));
    const double dx = (pose_(0) - last_pose_(0)) / dt, dy = (pose_(1) - last_pose_(1)) / dt;
    msg_.twist.twist.linear.x = c * dx + s * dy;
    msg_.twist.twist.linear.y = -s * dx + c * dy;
    msg_.twist.twist.angular.z = std::remainder(pose_(2) - last_pose_(2), 2 * M_PI) / dt;
  }
  msg_.header.stamp = stamp_of(t);
  msg_.pose.pose.position.x = pose_(0);
  msg_.pose.pose.position.y = pose_(1);
  msg_.pose.pose.orientation.z = std::sin(pose_(2) / 2);
  msg_.pose.pose.orientation.w = std::cos(pose_(2) / 2);
  out_.write(msg_);
  msgs::TransformStamped& tr = tf_.transforms[0];
  tr.header.stamp = msg_.header.stamp;
  tr.transform.translation.x = pose_(0);
  tr.transform.translation.y = pose_(1);
  tr.transform.rotation = msg_.pose.pose.orientation;
  tf_out_.write(tf_);
  last_pose_ = pose_;
  last_time_ = t;
  have_ = true;
}

DCA_REGISTER_CONTROLLER(BaseTwist);
DCA_REGISTER_CONTROLLER(BaseOdometry);

}  // namespace dca::ros2
