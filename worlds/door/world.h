#pragma once
// dca::sim::World: the door world (mobile manipulator + door) in Simbody, stepped at a fixed control period.
// C++17-clean: no Simbody types (pimpl). See worlds/door/models/README.md for the frames, poses and geometry.
//
// Time: step() advances exactly one control period (default 1 ms) with semi-explicit Euler (step = period).
// Commands set before step() act during that step. Sensors are those of the state after the last step.
//
// Signals (the future ports of `dca sim`; names stable, units SI, angles in radians):
//   out arm.q              [6]  joint angles of the arm (Puma 560 standard DH convention)
//   out arm.qd             [6]  joint rates (rad/s)
//   out base.pose          [3]  x, y (m), yaw (rad) of base_link in the world (odometry, exact, no drift)
//   out base.vel           [3]  vx, vy (m/s) in the base frame, yaw rate (rad/s)
//   out wrist.wrench       [6]  fx, fy, fz (N), tx, ty, tz (N m): what the tool (the sensor's tool side, the
//                                gripper and anything it holds or touches) exerts on the arm, in the ft_sensor
//                                frame, torque about its origin. Still and free: the tool's weight (9.3 N down).
//   out laser.range        [1]  distance (m) along laser_link's x axis to the door's plane (the wall: the
//                                closed leaf's approach face); laser_max_range if it does not hit
//   out camera.handle      [3]  u, v (pixels, origin top left, u right, v down) of the handle's grasp point
//                                in the camera image, and 1 if visible (in front and inside the image) else 0
//   out door.angle         [1]  hinge angle, 0 closed, positive open (pushed away from the robot)
//   out door.handle_angle  [1]  handle angle, 0 at rest, positive pressed down
//   out gripper.width      [1]  opening between the fingers (m), 0.09 fully open
//   out gripper.state      [1]  0 open, 1 closed (on nothing), 2 moving, 3 grasping the handle
//   in  base.cmd_vel       [3]  vx, vy (m/s) in the base frame, yaw rate (rad/s)
//   in  arm.cmd_qd         [6]  joint rate commands (rad/s)
//   in  gripper.cmd        [1]  0 open, 1 close
//
// Actuation: every robot joint (base x, y, yaw; 6 arm joints; 2 fingers) is driven by a stiff velocity servo
// with a position loop, as in real drives: a reference q_ref integrates the commanded rate (and is kept
// within a following-error bound of q) and a computed-torque law M (kv (u_cmd - u) + kp (q_ref - q)) + bias
// (gravity, Coriolis) gives forces, clamped at the URDF's effort limits. Forces, not prescribed motion, so
// that the arm stays compliant: contact and the grasp produce finite forces the wrist sensor reads, and a
// closed chain through the door is never over-constrained.
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <memory>
#include <string>

#include "worlds/door/door_model.h"

namespace dca::sim {

/// A pose in the floor plane.
struct Pose2 {
  double x = 0, y = 0, yaw = 0;
};

/// The simulated camera (a pinhole on camera_link looking along its x axis).
struct CameraParams {
  int width = 640, height = 480;  ///< pixels
  double hfov = 1.0471975511965976;  ///< horizontal field of view (rad), 60 degrees
};

/// Everything that defines a world. door_world() gives the standard one.
struct WorldConfig {
  double period = 1e-3;                    ///< control period = integration step (s)
  std::string robot_urdf;                  ///< path of the robot's URDF ("" = dca::models_dir()'s)
  DoorParams door;                         ///< the door (width etc.)
  Pose2 door_pose;                         ///< the door frame in the world (hinge axis at the floor)
  Pose2 base_start;                        ///< the robot's starting pose
  std::array<double, 6> arm_start{};       ///< the arm's starting joint angles
  CameraParams camera;
  double laser_max_range = 10.0;           ///< m
  double servo_bandwidth = 50.0;           ///< rad/s: the servos' natural frequency (critically damped)
  double following_error = 0.05;          ///< rad (m for the base and fingers): bound of q_ref - q
  double door_start = 0;                   ///< the door's starting angle (rad)
  double handle_start = 0;                 ///< the handle's starting angle (rad)
};

/// The nominal start pose of the robot (base at the origin facing +x, the door plane 2 m ahead).
Pose2 nominal_base_start();
/// The arm's ready pose: the gripper ahead of the base at handle height, pointing forward, fingers vertical.
std::array<double, 6> nominal_arm_start();
/// The standard door world: the door's handle at y = 0, its approach face at x = 2; with `seed` != 0 the
/// robot starts within +-0.3 m and +-15 degrees of the nominal pose and the door is 0.8-1.0 m wide, both
/// drawn from the seed (the same seed gives the same world). door_width > 0 overrides the width.
WorldConfig door_world(std::uint64_t seed = 0, double door_width = 0);

/// Robot commands (see the signals above).
struct Commands {
  std::array<double, 3> base_vel{};  ///< vx, vy (base frame, m/s), yaw rate (rad/s)
  std::array<double, 6> arm_qd{};    ///< rad/s
  bool gripper_close = false;
};

/// One of the signals above: its name, vector size and units.
struct Signal {
  const char* name;
  std::uint32_t size;
  const char* units;
};
/// The outputs (sensors), in the order above.
inline constexpr Signal kSensorSignals[] = {
    {"arm.q", 6, "rad"},
    {"arm.qd", 6, "rad/s"},
    {"base.pose", 3, "m, m, rad"},
    {"base.vel", 3, "m/s, m/s, rad/s"},
    {"wrist.wrench", 6, "N, N m"},
    {"laser.range", 1, "m"},
    {"camera.handle", 3, "px, px, 1"},
    {"door.angle", 1, "rad"},
    {"door.handle_angle", 1, "rad"},
    {"gripper.width", 1, "m"},
    {"gripper.state", 1, "0 open, 1 closed, 2 moving, 3 grasping"},
};
/// The inputs (commands), in the order above.
inline constexpr Signal kCommandSignals[] = {
    {"base.cmd_vel", 3, "m/s, m/s, rad/s"}, {"arm.cmd_qd", 6, "rad/s"}, {"gripper.cmd", 1, "0 open, 1 close"}};

/// Gripper state as published on gripper.state.
enum class GripperState { open = 0, closed = 1, moving = 2, grasping = 3 };

/// Sensor values (see the signals above).
struct Sensors {
  double time = 0;
  std::array<double, 6> arm_q{}, arm_qd{};
  std::array<double, 6> arm_effort{};  ///< N m: the arm drives' torques at this state (not a signal of its own)
  Pose2 base_pose;
  std::array<double, 3> base_vel{};
  std::array<double, 6> wrench{};
  double laser_range = 0;
  std::array<double, 3> camera_handle{};  ///< u, v, visible
  double door_angle = 0, handle_angle = 0;
  double gripper_width = 0;
  GripperState gripper = GripperState::open;
};

/// The world. Not thread-safe; deterministic: the same config and commands give the same sensors.
class World {
 public:
  /// Builds the world. Throws UrdfError (bad model) or std::invalid_argument (bad config).
  explicit World(const WorldConfig& config);
  ~World();
  World(const World&) = delete;
  World& operator=(const World&) = delete;

  /// Sets the commands for the following steps.
  void set_commands(const Commands& c);
  /// Advances one control period.
  void step();
  /// The sensors after the last step (or at the start).
  const Sensors& sensors() const;
  /// Simulated time (s).
  double time() const;
  const WorldConfig& config() const;

  // --- ground truth, for tests, scripted demos and plots (not for controllers) ---
  /// A link's frame in the world (robot links and door links: door_frame, door_leaf, door_handle, door_grasp).
  Eigen::Isometry3d link_pose(const std::string& link) const;
  /// Jacobian of tool0 (its origin; rows: angular then linear velocity, world frame) w.r.t. the 6 arm joints.
  Eigen::Matrix<double, 6, 6> tool_jacobian() const;
  /// True while the grasp constraint holds the handle.
  bool grasping() const;
  /// True while the latch holds the door.
  bool latched() const;
  /// External torques (N m) on the door's hinge (positive opens) and on the handle (positive presses), as a
  /// person would apply: for tests and scenarios. They stay until changed.
  void set_disturbance(double hinge_torque, double handle_torque);

  /// Shows the world in Simbody's 3-D visualizer (about 30 frames per simulated second) from now on. Needs a
  /// display; Debian's simbody-visualizer is found through a SIMBODY_HOME made for it. False with *error
  /// saying why it did not start (the world runs on either way).
  bool start_visualizer(std::string* error);

  /// The Simbody side (defined in world.cpp only).
  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace dca::sim
