#pragma once
// The robot's signals, as the door-opening controllers (controllers/door/) and the drivers here exchange them:
//   Vel     vector[9]  a motion command in the robot's base frame: a tool0 twist (vx, vy, vz in m/s, wx, wy, wz
//                      in rad/s) *on top of* the motion that the command's base velocity (vx, vy in m/s, yaw
//                      rate in rad/s, the last three) gives the whole robot. RedundancyResolution drives the base
//                      at that velocity and spreads the extra twist over base and arm. So [0, b] moves the robot
//                      rigidly, [t, 0] moves the tool by t, and [-b_lin, 0, b] moves the base under a still tool.
//   Joints  vector[6]  the arm's joint angles (rad), Puma 560 order, as arm.q of the world.
//   Wrench  vector[6]  force (N) and torque (N m) the tool exerts on the wrist sensor, sensor frame.
//   Pose    vector[3]  the base's pose in the world: x, y (m), yaw (rad).
//   Feature vector[3]  the handle's grasp point in the camera image: u, v (pixels), visible (1/0).
//
// Hardware-facing controllers (controllers/robot/) reach the robot through *device ports*: ports whose PortSpec
// names a signal of the robot process (`dca sim`, or a real robot's driver process registered as "world"). The
// supervisor that owns the controller connects its device ports to those signals when it connects its group,
// always active. Everything else reaches its inputs through the .dca file's connections.
//
// The drives (XR4000Ctrl, Puma560Ctrl, RedundancyResolution) use a command while it is younger than `hold`
// (default 0.01 s, the period of the controllers that command them), then count it as zero: at 10 ms a command
// not refreshed since the previous tick is zero, and a drive faster than its source (MotionControl at 1 ms)
// holds each sample until the next one is due. A crashed or stopped source leaves the robot still within `hold`.
#include <Eigen/Core>
#include <string>

#include <dca/controller.h>

namespace dca::robot {

using Vec3 = Eigen::Matrix<double, 3, 1>;
using Vec6 = Eigen::Matrix<double, 6, 1>;
using Vec9 = Eigen::Matrix<double, 9, 1>;

/// The signals' units, as their ports declare them.
inline constexpr const char* kVelUnits = "Vel";
inline constexpr const char* kJointsUnits = "rad";
inline constexpr const char* kWrenchUnits = "N, N m";
inline constexpr const char* kPoseUnits = "m, m, rad";
inline constexpr const char* kFeatureUnits = "px, px, 1";

/// An input or output of one of the signals above, named `name`.
inline InSpec<Vec9> VelIn(std::string name = "Vel") { return {.name = std::move(name), .units = kVelUnits}; }
inline OutSpec<Vec9> VelOut(std::string name = "Vel") { return {.name = std::move(name), .units = kVelUnits}; }
inline InSpec<Vec6> JointsIn(std::string name = "Joints") { return {.name = std::move(name), .units = kJointsUnits}; }
inline OutSpec<Vec6> JointsOut(std::string name = "Joints") {
  return {.name = std::move(name), .units = kJointsUnits};
}
inline InSpec<Vec6> WrenchIn(std::string name = "Wrench") { return {.name = std::move(name), .units = kWrenchUnits}; }
inline InSpec<Vec3> PoseIn(std::string name = "Pose") { return {.name = std::move(name), .units = kPoseUnits}; }
inline InSpec<Vec3> FeatureIn(std::string name = "Feature") {
  return {.name = std::move(name), .units = kFeatureUnits};
}

/// The drives' parameter "hold".
inline Param<double> HoldParam() {
  return {.name = "hold", .doc = "a command older than this (s) counts as zero (a drive's deadman)", .def = 0.01,
          .above = 0};
}

/// A drive's command: the newest sample of its input, used for `hold` after it arrived, then zero (a deadman).
template <int N>
class HeldCommand {
 public:
  using Vec = Eigen::Matrix<double, N, 1>;
  explicit HeldCommand(double hold_s) : hold_(static_cast<Nanos>(hold_s * 1e9)) {}
  /// The command at `now`: a sample that arrived since the last call, else the last one while it is younger
  /// than `hold`, else zero.
  const Vec& update(In<Vec>& in, Nanos now) {
    if (in.read(v_) == Read::New) at_ = now;
    else if (at_ < 0 || now - at_ >= hold_) v_.setZero();
    return v_;
  }
  /// Forgets the last command (a new run starts from zero).
  void reset() {
    v_.setZero();
    at_ = -1;
  }

 private:
  Nanos hold_;
  Nanos at_ = -1;
  Vec v_ = Vec::Zero();
};

}  // namespace dca::robot
