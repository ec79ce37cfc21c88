#pragma once
// A robot described by a URDF file, as the generic URDF world reads it (docs/robots.md): its moving joints with
// their limits and their command interfaces (ros2_control tags), checked so that every error names FILE:LINE:COL
// and the element. C++17-clean: no Simbody types.
//
// Checks made on the XML (TinyXML, with line numbers) before urdfdom builds its tree:
//   - the file is well-formed XML with a <robot> root (a truncated file says where it ends);
//   - every joint has a type among fixed, revolute, continuous, prismatic, floating, planar, and names a parent
//     and a child link that are defined;
//   - no link is the child of two joints, and no chain of joints comes back to where it started (a kinematic
//     loop: URDF describes trees);
//   - a link moved by a joint other than fixed has an <inertial>;
//   - a <ros2_control> joint names a moving joint of the model, with command interfaces position, velocity or
//     effort, and numbers where numbers are due;
//   - a <ros2_control> sensor (force-torque, IMU, odometry) names a link, or a fixed joint for force-torque, of
//     the model, and only state interfaces of its kind.
// Then urdfdom's own checks and the inertia checks of sim/urdf_parse.h.
// Meshes are visuals only: a <mesh filename> that cannot be found (package:// resolved through
// $DCA_PACKAGE_PATH, then $ROS_PACKAGE_PATH; a relative path from the URDF's folder) is a warning naming it.
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "sim/urdf_parse.h"

namespace dca::sim {

/// A command interface of a joint (ros2_control's command_interface names).
enum class JointInterface : std::uint8_t { position, velocity, effort };
/// "position", "velocity" or "effort".
const char* to_string(JointInterface i);

/// What a command interface does when its command goes stale (no sample for `watchdog_ticks` world steps) or
/// its writer is lost: keep the last command, or apply the interface's zero (velocity 0, effort 0; for a
/// position interface: stay where the joint is when it went stale).
enum class OnStale : std::uint8_t { hold, zero };

/// One command interface of a joint, with its declared parameters (<param> inside the ros2_control joint or
/// inside the command_interface; the latter wins).
struct CommandSpec {
  JointInterface kind = JointInterface::effort;
  int watchdog_ticks = 100;          ///< world steps without a sample after which the command is stale (0: never)
  OnStale on_stale = OnStale::zero;  ///< default: hold for position, zero for velocity and effort
  double min = -std::numeric_limits<double>::infinity();  ///< <param name="min">: a further bound
  double max = std::numeric_limits<double>::infinity();   ///< <param name="max">
  /// Servo gains (position: p on the error, i on its integral, d on the joint's velocity; velocity: p on the
  /// velocity error, i on its integral). NaN: the default, from the joint's inertia (docs/robots.md).
  double p = std::numeric_limits<double>::quiet_NaN();
  double i = std::numeric_limits<double>::quiet_NaN();
  double d = std::numeric_limits<double>::quiet_NaN();
  std::string where;                 ///< "FILE:LINE:COL" of the element that declared it
};

/// A URDF <limit> and <safety_controller> of a joint. Infinite where the URDF gives no bound.
struct JointLimitSpec {
  double lower = -std::numeric_limits<double>::infinity(), upper = std::numeric_limits<double>::infinity();
  double velocity = std::numeric_limits<double>::infinity();  ///< |qd| bound (0 or absent in the URDF: none)
  double effort = std::numeric_limits<double>::infinity();    ///< |effort| bound (0 or absent: none)
  bool soft = false;                 ///< a <safety_controller> is declared
  double soft_lower = -std::numeric_limits<double>::infinity(), soft_upper = std::numeric_limits<double>::infinity();
  double k_position = 0, k_velocity = 0;
};

/// A moving joint (revolute, continuous, prismatic) with its device ports.
struct JointSpec {
  std::string name;
  int type = 0;                      ///< urdf::Joint type
  bool linear = false;               ///< prismatic: metres and newtons (else radians and newton metres)
  JointLimitSpec limits;
  std::vector<CommandSpec> commands; ///< declared order; the first is the one in force at the start
  double initial = 0;                ///< start position (the position state interface's initial_value, else 0
                                     ///< brought within the limits)
  std::string where;                 ///< "FILE:LINE:COL" of the <joint> element
};

/// What a ros2_control <sensor> measures (docs/robots.md, "Sensors"): its kind follows from its state
/// interfaces (force.x .. torque.z; orientation.x .. linear_acceleration.z; pose.x .. twist.yaw).
enum class SensorKind : std::uint8_t { force_torque, imu, odometry };
/// "force_torque", "imu" or "odometry".
const char* to_string(SensorKind k);

/// A sensor of the robot: a <sensor> of <ros2_control> with its state interfaces and parameters.
struct SensorSpec {
  std::string name;
  SensorKind kind = SensorKind::imu;
  std::string link;                  ///< the frame of its readings: FT the joint's child link; IMU, odometry the link
  std::string joint;                 ///< FT: the fixed joint it measures across
  bool child_to_parent = true;       ///< FT: the wrench the child side applies on the parent (else the reverse)
  std::vector<std::string> groups;   ///< the groups of interfaces declared (force, torque, ...), in canonical order
  std::string where;                 ///< "FILE:LINE:COL" of the <sensor> element
};

/// Options of loading.
struct DescriptionOptions {
  /// The command interface of every moving joint when the file declares no <ros2_control> joint at all.
  JointInterface default_command = JointInterface::effort;
};

/// A URDF robot: the parsed model (for the Simbody world), its moving joints and the warnings of loading.
struct RobotDescription {
  ParsedUrdf urdf;
  std::string name;                  ///< the <robot name>
  std::string text;                  ///< the URDF's text, as read (for viewers: /robot_description)
  std::vector<JointSpec> joints;     ///< revolute, continuous and prismatic joints, in document order
  bool declared = false;             ///< the file has <ros2_control> joints (else every joint has the default)
  std::vector<SensorSpec> sensors;   ///< ros2_control sensors, in document order
  std::vector<std::string> warnings; ///< "FILE:LINE:COL: mesh 'URI' not found (...)": the visual is left out
  /// The joint named `name`, or nullptr.
  const JointSpec* joint(const std::string& joint_name) const;
};

/// Reads and checks the URDF file at `path`. Throws UrdfError ("FILE:LINE:COL: joint 'NAME': reason").
RobotDescription load_description(const std::string& path, const DescriptionOptions& options = {});
/// Same for URDF text; `name` stands for the file in messages, `dir` resolves relative mesh paths.
RobotDescription load_description_string(const std::string& text, const std::string& name, const std::string& dir,
                                         const DescriptionOptions& options = {});

/// The file a mesh URI names (package://PKG/PATH through the search path, file://PATH, or a path relative to
/// `dir`), or "" when it cannot be found. `searched` gets the folders looked in, for the warning.
std::string resolve_mesh(const std::string& uri, const std::string& dir, std::string* searched);

}  // namespace dca::sim
