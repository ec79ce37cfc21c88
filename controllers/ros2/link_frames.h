#pragma once
// The process type LinkFrames (docs/ros2.md, "The examples"): a URDF world's link frames (its output
// links.frames, docs/robots.md "Link frames") as one tf2_msgs/msg/TFMessage, what ROS 2's robot_state_publisher
// publishes on /tf:
//   in  Frames  vectorx device links.frames: 7 numbers per frame (x y z, qx qy qz qw), the child in its parent
//   out Tf      tf2_msgs/msg/TFMessage: one TransformStamped per frame, header.frame_id the parent,
//               child_frame_id the child, stamped with the clock's time (simulated or wall)
// The argument `frames` names the frames in links.frames' order, rows "PARENT CHILD" separated by ';' (at most
// kMaxTransforms): the world's request robot_description answers them, and `dca types --world` lists them. A
// sample of another size than 7 per row ends the run ABORTED, naming both sizes.
#include <string>

#include <Eigen/Core>

#include <dca/controller.h>
#include <dca/msgs.h>

namespace dca::ros2 {

class LinkFrames final : public PeriodicController {
  DCA_CONTROLLER(LinkFrames)

 private:
  void on_start(const msgpack::object& init) override;
  void MainCalc() override;

  In<Eigen::VectorXd> in_;
  Out<msgs::TFMessage> out_;
  msgs::TFMessage msg_;
  Eigen::VectorXd sample_;
  bool have_ = false;
};

}  // namespace dca::ros2
