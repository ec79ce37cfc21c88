#pragma once
// The approach to the door: visual servoing on the handle (paper, section 5).
#include <Eigen/Geometry>
#include <optional>

#include <dca/robot/signals.h>

namespace dca::door {

/// VisualServoing(host, speed=0.25, gain=1.5, hfov=1.0472, width=640, lost=0.5, height=480, handle_height=1,
/// lateral=-0.075, period=0.01): drives the robot towards the handle (servoing on one point feature). The handle's
/// image point and its known height above the floor (`handle_height`, m) give its position in the base frame
/// (the camera's pose comes from the robot's URDF); the robot moves forward at `speed` and turns so that the line
/// straight ahead of the base at `lateral` m (where the gripper is: the approach that follows moves the tool
/// straight ahead) passes through the handle. When the feature's ray does not reach that height it turns to
/// centre the handle in the image instead.
///   in  Feature  vector[3] from HandleCamera
///   out Vel      vector[9] the whole robot moves rigidly (base velocity only)
/// ABORTED when the handle has not been visible for `lost` seconds.
class VisualServoing final : public PeriodicController {
  DCA_CONTROLLER(VisualServoing)

 public:
  using Vec9 = robot::Vec9;
  /// The command for a feature at column u: forward at `speed`, turning to centre u.
  static Vec9 Law(double u, double speed, double gain, double focal_px, double centre_u);
  /// Where the handle is in the base frame (x, y), from its image point (u, v), the camera's pose in the base
  /// frame (x along the optical axis, y left, z up), the focal length and image centre in pixels and the
  /// handle's height above the floor; nothing when the pixel's ray does not go down to that height ahead.
  static std::optional<Eigen::Vector2d> Locate(double u, double v, const Eigen::Isometry3d& camera, double focal_px,
                                               double centre_u, double centre_v, double height);
  /// The command for a handle at `handle` (base frame): forward at `speed`, turning (gain 1/s) so that the line
  /// y = `lateral` ahead of the base passes through it.
  static Vec9 Steer(const Eigen::Vector2d& handle, double lateral, double speed, double gain);

 private:
  void on_start(const msgpack::object& init) override;
  void MainCalc() override;

  In<robot::Vec3> feature_;
  Out<Vec9> vel_;
  double speed_, gain_, focal_, centre_u_, centre_v_, lost_, handle_height_, lateral_;
  Eigen::Isometry3d camera_ = Eigen::Isometry3d::Identity();
  robot::Vec3 f_ = robot::Vec3::Zero();
  Nanos last_seen_ = 0;
  Vec9 v_ = Vec9::Zero();
};

}  // namespace dca::door
