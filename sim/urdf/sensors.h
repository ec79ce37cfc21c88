#pragma once
// The sensors of a URDF robot (docs/robots.md, "Sensors"): force-torque sensors at fixed joints, IMUs on links and
// odometry of a planar mobile base, declared as <sensor> elements of <ros2_control>. Each group of state
// interfaces a sensor declares (force, torque; orientation, angular_velocity, linear_acceleration; pose, twist)
// is one output port `sensor.NAME.GROUP`. Here: the groups, the ports, and the readings of the mock hardware from
// the joints' states (forward kinematics, quasi-static). The Simbody world computes its own (urdf_world.cpp).
// C++17-clean: no Simbody types.
#include <cstddef>
#include <string>
#include <vector>

#include "sim/device_world.h"
#include "sim/urdf/description.h"
#include "sim/urdf/joint_interfaces.h"

namespace dca::sim {

constexpr double kGravity = 9.81;  ///< m/s², along -z of the world, as the Simbody world's

/// A group of state interfaces: its name and its components, in the order of the port's values.
struct SensorGroup {
  const char* name;
  std::vector<const char*> components;
  const char* units;
};
/// The groups of a kind, in canonical order: force_torque {force xyz, torque xyz}; imu {orientation xyzw,
/// angular_velocity xyz, linear_acceleration xyz}; odometry {pose x y yaw, twist x y yaw}.
const std::vector<SensorGroup>& sensor_groups(SensorKind kind);
/// The kind whose group `group` is, or false.
bool sensor_kind_of(const std::string& group, SensorKind* kind);
/// The values of one sensor's reading, all its groups in canonical order (6, 10 or 6).
std::size_t sensor_values(SensorKind kind);

/// One output port of a sensor: `sensor.NAME.GROUP`, a slice of the sensor's reading.
struct SensorPort {
  std::size_t sensor = 0;   ///< into RobotDescription::sensors
  std::size_t offset = 0;   ///< of the group in the sensor's reading
  std::size_t size = 0;
};
/// The ports of `d`'s sensors, per sensor in document order, per declared group in canonical order.
std::vector<SensorPort> sensor_ports(const RobotDescription& d);
std::vector<DeviceSignal> sensor_signals(const RobotDescription& d);

/// The mock's readings: from the joints' positions and velocities by forward kinematics of the URDF, with the
/// robot taken as still (quasi-static): a force-torque sensor reads the weight of the links below its joint and
/// their moment about its child link's origin; an IMU reads the link's orientation, the angular velocity of the
/// joints' motion and the reaction to gravity (+9.81 m/s² up) without the link's own acceleration; odometry reads
/// the link's planar pose and the velocity of the joints' motion.
class MockSensors {
 public:
  explicit MockSensors(const RobotDescription& d);
  /// Every sensor's reading, one after another (sensor_values(kind) each), into `out`.
  void read(const std::vector<JointState>& state, std::vector<double>& out) const;

 private:
  const RobotDescription& d_;
};

/// The planar pose of a frame with rotation matrix R (row-major 3x3) at p: x, y, yaw.
double yaw_of(const double* R);

}  // namespace dca::sim
