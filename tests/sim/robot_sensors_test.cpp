// The sensors of the URDF worlds (docs/robots.md, "Sensors"), on tests/sim/robots/sensor_rover.urdf: ros2_control
// <sensor> declarations become ports sensor.NAME.GROUP; a force-torque sensor reads the static load below its
// fixed joint, an IMU reads +g along its link's up axis at rest and the rate when spinning, odometry follows the
// commanded base, in the Simbody world and on the mock hardware; broken declarations name FILE:LINE:COL.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "sim/urdf/joint_world.h"
#include "tests/support/temp_dir.h"

namespace {

using dca::sim::JointWorld;

const std::string kRover = std::string(DCA_SOURCE_DIR) + "/tests/sim/robots/sensor_rover.urdf";
constexpr double kG = 9.81;

std::vector<double> read(const JointWorld& w, const std::string& name) {
  const std::size_t i = dca::sim::signal_index(w.sensors(), name);
  EXPECT_LT(i, w.sensors().size()) << name;
  if (i >= w.sensors().size()) return {};
  std::vector<double> v(w.sensors()[i].size);
  w.sensor(i, v.data());
  return v;
}

void send(JointWorld& w, const std::string& name, double v) {
  const std::size_t i = dca::sim::signal_index(w.commands(), name);
  ASSERT_LT(i, w.commands().size()) << name;
  w.command(i, &v, 1);
}

void steps(JointWorld& w, int n) {
  for (int i = 0; i < n; ++i) w.step();
}

// `n` steps with the commands `cmds` sent every 50 steps (within the watchdogs' 100).
void drive(JointWorld& w, const std::vector<std::pair<std::string, double>>& cmds, int n) {
  for (int i = 0; i < n; ++i) {
    if (i % 50 == 0)
      for (const auto& [name, v] : cmds) send(w, name, v);
    w.step();
  }
}

void expect_near(const std::vector<double>& got, const std::vector<double>& want, double tolerance,
                 const std::string& what) {
  ASSERT_EQ(got.size(), want.size()) << what;
  for (std::size_t k = 0; k < want.size(); ++k) EXPECT_NEAR(got[k], want[k], tolerance) << what << "[" << k << "]";
}

// Both worlds of the rover: Simbody, then mock.
std::vector<std::unique_ptr<JointWorld>> worlds() {
  std::vector<std::unique_ptr<JointWorld>> out;
  out.push_back(dca::sim::make_robot_world(kRover, 1e-3));
  out.push_back(dca::sim::make_robot_world("mock:" + kRover, 1e-3));
  return out;
}

TEST(RobotSensorsTest, SensorsAreDeclaredAndBecomePorts) {
  const auto d = dca::sim::load_description(kRover);
  ASSERT_EQ(d.sensors.size(), 5u);
  EXPECT_EQ(d.sensors[0].kind, dca::sim::SensorKind::force_torque);
  EXPECT_EQ(d.sensors[0].joint, "flange_joint");
  EXPECT_EQ(d.sensors[0].link, "flange");
  EXPECT_EQ(d.sensors[1].kind, dca::sim::SensorKind::imu);
  EXPECT_EQ(d.sensors[4].kind, dca::sim::SensorKind::odometry);
  EXPECT_TRUE(d.warnings.empty()) << d.warnings[0];
  auto w = dca::sim::make_robot_world(kRover, 1e-3);
  std::vector<std::string> ports;
  for (const auto& s : w->sensors())
    if (s.name.rfind("sensor.", 0) == 0) ports.push_back(s.name + "[" + std::to_string(s.size) + "]");
  EXPECT_EQ(ports, (std::vector<std::string>{
                       "sensor.wrist_ft.force[3]", "sensor.wrist_ft.torque[3]", "sensor.base_imu.orientation[4]",
                       "sensor.base_imu.angular_velocity[3]", "sensor.base_imu.linear_acceleration[3]",
                       "sensor.rolled_imu.orientation[4]", "sensor.rolled_imu.linear_acceleration[3]",
                       "sensor.tool_imu.angular_velocity[3]", "sensor.tool_imu.linear_acceleration[3]",
                       "sensor.odometry.pose[3]", "sensor.odometry.twist[3]"}));
}

// The tool (3 kg, its centre of mass 0.1 m along the flange's x) hangs below the flange: the sensor reads its
// weight down and its moment about the flange's y, in the flange's frame, however the arm is turned.
TEST(RobotSensorsTest, AForceTorqueSensorReadsTheStaticLoadBelowIt) {
  for (auto& w : worlds()) {
    expect_near(read(*w, "sensor.wrist_ft.force"), {0, 0, -3 * kG}, 1e-6, w->describe() + " at the start");
    send(*w, "joint.arm_joint.position_command", 1.0);
    steps(*w, 2000);
    expect_near(read(*w, "sensor.wrist_ft.force"), {0, 0, -3 * kG}, 1e-3, w->describe());
    expect_near(read(*w, "sensor.wrist_ft.torque"), {0, 0.1 * 3 * kG, 0}, 1e-3, w->describe());
  }
}

TEST(RobotSensorsTest, AnImuAtRestReadsGravityAlongItsLinksUpAxis) {
  for (auto& w : worlds()) {
    steps(*w, 100);
    expect_near(read(*w, "sensor.base_imu.orientation"), {0, 0, 0, 1}, 1e-9, w->describe());
    expect_near(read(*w, "sensor.base_imu.angular_velocity"), {0, 0, 0}, 1e-9, w->describe());
    expect_near(read(*w, "sensor.base_imu.linear_acceleration"), {0, 0, kG}, 1e-6, w->describe());
    // imu_link is rolled by 90 degrees about x: its y axis is up
    expect_near(read(*w, "sensor.rolled_imu.orientation"), {std::sqrt(0.5), 0, 0, std::sqrt(0.5)}, 1e-9, w->describe());
    expect_near(read(*w, "sensor.rolled_imu.linear_acceleration"), {0, kG, 0}, 1e-6, w->describe());
  }
}

// Spinning the base at 1 rad/s: both IMUs read the rate about z; the tool's, 0.5 m from the axis, also reads
// the centripetal 0.5 m/s² towards it in the Simbody world (the mock is quasi-static: gravity only), and the
// force-torque sensor the tool's centripetal pull.
TEST(RobotSensorsTest, AnImuOnASpinningBaseReadsItsRate) {
  auto w = worlds();
  for (std::size_t k = 0; k < w.size(); ++k) {
    drive(*w[k], {{"joint.base_yaw_joint.velocity_command", 1.0}, {"joint.arm_joint.position_command", 0.0}}, 1500);
    expect_near(read(*w[k], "sensor.base_imu.angular_velocity"), {0, 0, 1}, 2e-3, w[k]->describe());
    expect_near(read(*w[k], "sensor.tool_imu.angular_velocity"), {0, 0, 1}, 2e-3, w[k]->describe());
    const double centripetal = k == 0 ? -0.5 : 0.0;
    expect_near(read(*w[k], "sensor.tool_imu.linear_acceleration"), {centripetal, 0, kG}, 1e-2, w[k]->describe());
    // the tool's centre of mass, 0.6 m out, pulls the flange outwards by 3 kg x 0.6 m/s² (the mock: static)
    expect_near(read(*w[k], "sensor.wrist_ft.force"), {k == 0 ? 1.8 : 0.0, 0, -3 * kG}, 1e-2, w[k]->describe());
    expect_near(read(*w[k], "sensor.wrist_ft.torque"), {0, 0.1 * 3 * kG, 0}, 1e-2, w[k]->describe());
    const double yaw = read(*w[k], "joint.base_yaw_joint.position")[0];
    const auto q = read(*w[k], "sensor.base_imu.orientation");
    expect_near(q, {0, 0, std::sin(yaw / 2), std::cos(yaw / 2)}, 1e-9, w[k]->describe());
  }
}

// The base driven in x, y and yaw: odometry's pose is where the joints put base_link, its twist the base's
// velocity in its own frame (forward, left, yaw rate).
TEST(RobotSensorsTest, OdometryFollowsACommandedBaseMotion) {
  for (auto& w : worlds()) {
    drive(*w, {{"joint.base_x_joint.velocity_command", 0.5}, {"joint.base_y_joint.velocity_command", -0.2},
               {"joint.base_yaw_joint.velocity_command", 0.3}}, 2000);
    const double x = read(*w, "joint.base_x_joint.position")[0], y = read(*w, "joint.base_y_joint.position")[0];
    const double yaw = read(*w, "joint.base_yaw_joint.position")[0];
    EXPECT_NEAR(x, 0.5 * 2, 0.02) << w->describe();
    EXPECT_NEAR(yaw, 0.3 * 2, 0.02) << w->describe();
    expect_near(read(*w, "sensor.odometry.pose"), {x, y, yaw}, 1e-9, w->describe());
    const double c = std::cos(yaw), s = std::sin(yaw);
    expect_near(read(*w, "sensor.odometry.twist"), {c * 0.5 - s * 0.2, -s * 0.5 - c * 0.2, 0.3}, 2e-3,
                w->describe());
  }
}

// Broken declarations: each names FILE:LINE:COL, the sensor and what is wrong.
class BrokenSensors : public ::testing::Test {
 protected:
  std::string error_of(const std::string& name, const std::string& sensor) {
    const std::string path = dir_.path() + "/" + name;
    std::ofstream(path) << "<robot name=\"r\">\n"
                           "  <link name=\"a\"/>\n"
                           "  <link name=\"b\"><inertial><mass value=\"1\"/><inertia ixx=\"0.1\" ixy=\"0\" ixz=\"0\" "
                           "iyy=\"0.1\" iyz=\"0\" izz=\"0.1\"/></inertial></link>\n"
                           "  <link name=\"c\"/>\n"
                           "  <joint name=\"j\" type=\"revolute\"><parent link=\"a\"/><child link=\"b\"/><axis xyz=\"0 0 1\"/>"
                           "<limit lower=\"-1\" upper=\"1\" effort=\"10\" velocity=\"1\"/></joint>\n"
                           "  <joint name=\"f\" type=\"fixed\"><parent link=\"b\"/><child link=\"c\"/></joint>\n"
                           "  <ros2_control name=\"x\" type=\"system\">\n"
                        << sensor << "  </ros2_control>\n</robot>\n";
    try {
      dca::sim::load_description(path);
    } catch (const dca::sim::UrdfError& e) {
      return e.what();
    }
    return "no error";
  }
  dca::test::TempDir dir_{"robot_sensors_test"};
};

TEST_F(BrokenSensors, NameTheirFileLineAndElement) {
  const std::string d = dir_.path() + "/";
  const std::string ft = "    <sensor name=\"ft\">\n      <state_interface name=\"force.z\"/>\n";
  EXPECT_EQ(error_of("unknown_joint.urdf", ft + "      <param name=\"joint\">nope</param>\n    </sensor>\n"),
            d + "unknown_joint.urdf:10:7: ros2_control sensor 'ft': joint 'nope' is not a joint of the model");
  EXPECT_EQ(error_of("moving_joint.urdf", ft + "      <param name=\"joint\">j</param>\n    </sensor>\n"),
            d + "moving_joint.urdf:10:7: ros2_control sensor 'ft': joint 'j' is revolute: a force_torque sensor "
                "measures across a fixed joint (" + d + "moving_joint.urdf:5:3)");
  EXPECT_EQ(error_of("no_joint.urdf", ft + "    </sensor>\n"),
            d + "no_joint.urdf:8:5: ros2_control sensor 'ft': a force_torque sensor needs <param name=\"joint\"> "
                "naming a fixed joint");
  EXPECT_EQ(error_of("unknown_link.urdf", "    <sensor name=\"imu\">\n      <state_interface name=\"orientation.w\"/>\n"
                                          "      <param name=\"frame_id\">ghost</param>\n    </sensor>\n"),
            d + "unknown_link.urdf:10:7: ros2_control sensor 'imu': link 'ghost' is not a link of the model");
  EXPECT_EQ(error_of("interface.urdf", ft + "      <state_interface name=\"force.w\"/>\n"
                                            "      <param name=\"joint\">f</param>\n    </sensor>\n"),
            d + "interface.urdf:10:7: ros2_control sensor 'ft': state interface 'force.w' is not one of a force_torque "
                "sensor (force.x, force.y, force.z, torque.x, torque.y, torque.z)");
  EXPECT_EQ(error_of("direction.urdf", ft + "      <param name=\"joint\">f</param>\n"
                                            "      <param name=\"measure_direction\">down</param>\n    </sensor>\n"),
            d + "direction.urdf:11:7: ros2_control sensor 'ft': measure_direction is child_to_parent or "
                "parent_to_child, not 'down'");
  const std::string imu = "    <sensor name=\"imu\">\n      <state_interface name=\"orientation.w\"/>\n"
                          "      <param name=\"frame_id\">b</param>\n    </sensor>\n";
  EXPECT_EQ(error_of("twice.urdf", imu + imu),
            d + "twice.urdf:12:5: ros2_control sensor 'imu' is declared twice (first at " + d + "twice.urdf:8:5)");
  // a sensor of a kind not simulated (a range finder) loads, left out with a warning, as before
  EXPECT_EQ(error_of("range.urdf", "    <sensor name=\"sonar\">\n      <state_interface name=\"range\"/>\n"
                                   "    </sensor>\n"),
            "no error");
  // found by frame_id alone: the fixed joint whose child it is
  const auto ok = dca::sim::load_description(d + "range.urdf");
  EXPECT_TRUE(ok.sensors.empty());
  ASSERT_EQ(ok.warnings.size(), 1u);
  EXPECT_NE(ok.warnings[0].find("<sensor> 'sonar' of ros2_control is not simulated"), std::string::npos) << ok.warnings[0];
  EXPECT_EQ(error_of("frame.urdf", ft + "      <param name=\"frame_id\">c</param>\n    </sensor>\n"), "no error");
  EXPECT_EQ(dca::sim::load_description(d + "frame.urdf").sensors.at(0).joint, "f");
}

}  // namespace
