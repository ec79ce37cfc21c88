// The URDF world's loader (sim/urdf/description.h): the UR10 of worlds/ur10 and a many-joint robot written in an
// unusual style load with their ports; broken files give FILE:LINE:COL naming the element; a mesh that cannot be
// found is a warning naming it.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "sim/urdf/description.h"
#include "sim/urdf/frames.h"
#include "sim/urdf/joint_interfaces.h"
#include "sim/urdf_bodies.h"
#include "tests/support/temp_dir.h"

namespace {

namespace fs = std::filesystem;
using dca::sim::JointInterface;
using dca::sim::load_description;

const std::string kSource = DCA_SOURCE_DIR;
const std::string kUr10 = kSource + "/worlds/ur10/ur10.urdf";

const dca::test::TempDir& temp() {
  static const dca::test::TempDir dir("robot_description_test");
  return dir;
}

std::string write(const std::string& name, const std::string& text) {
  const std::string path = (fs::path(temp().path()) / name).string();
  std::ofstream(path) << text;
  return path;
}

// The error of loading `text` as file `name`, or "" when it loads.
std::string error_of(const std::string& name, const std::string& text) {
  try {
    load_description(write(name, text));
  } catch (const dca::sim::UrdfError& e) {
    return e.what();
  }
  return "";
}

// Standard Denavit-Hartenberg: Rz(theta) Tz(d) Tx(a) Rx(alpha).
Eigen::Isometry3d dh(double theta, double d, double a, double alpha) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.rotate(Eigen::AngleAxisd(theta, Eigen::Vector3d::UnitZ()));
  T.translate(Eigen::Vector3d(0, 0, d));
  T.translate(Eigen::Vector3d(a, 0, 0));
  T.rotate(Eigen::AngleAxisd(alpha, Eigen::Vector3d::UnitX()));
  return T;
}

Eigen::Isometry3d ur10_dh(const std::vector<double>& q) {
  const double d[6] = {0.1273, 0, 0, 0.163941, 0.1157, 0.0922}, a[6] = {0, -0.612, -0.5723, 0, 0, 0};
  const double alpha[6] = {M_PI / 2, 0, 0, M_PI / 2, -M_PI / 2, 0};
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  for (int i = 0; i < 6; ++i) T = T * dh(q[static_cast<size_t>(i)], d[i], a[i], alpha[i]);
  return T;
}

TEST(RobotDescriptionTest, Ur10LoadsWithItsInterfacesAndLimits) {
  const auto d = load_description(kUr10);
  EXPECT_EQ(d.name, "ur10");
  EXPECT_TRUE(d.declared);
  EXPECT_TRUE(d.warnings.empty());
  ASSERT_EQ(d.joints.size(), 6u);
  const char* names[] = {"shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint",
                         "wrist_1_joint",      "wrist_2_joint",       "wrist_3_joint"};
  const double effort[] = {330, 330, 150, 56, 56, 56};
  for (size_t i = 0; i < 6; ++i) {
    const auto& j = d.joints[i];
    EXPECT_EQ(j.name, names[i]);
    EXPECT_EQ(j.limits.effort, effort[i]);
    ASSERT_EQ(j.commands.size(), 2u);
    EXPECT_EQ(j.commands[0].kind, JointInterface::position);
    EXPECT_EQ(j.commands[0].on_stale, dca::sim::OnStale::hold);
    EXPECT_EQ(j.commands[1].kind, JointInterface::velocity);
    EXPECT_EQ(j.commands[1].on_stale, dca::sim::OnStale::zero);
    EXPECT_EQ(j.commands[1].watchdog_ticks, 100);
    EXPECT_TRUE(j.limits.soft);
  }
  EXPECT_NEAR(d.joint("elbow_joint")->limits.upper, M_PI, 1e-6);
  EXPECT_NEAR(d.joint("shoulder_pan_joint")->limits.upper, 2 * M_PI, 1e-6);
  EXPECT_NEAR(d.joint("shoulder_lift_joint")->initial, -M_PI / 2, 1e-6);
  EXPECT_NEAR(d.joint("shoulder_pan_joint")->limits.velocity, 2.0944, 1e-9);
  EXPECT_EQ(dca::sim::joint_command_signals(d).size(), 12u);
  const auto out = dca::sim::joint_sensor_signals(d);
  ASSERT_EQ(out.size(), 21u);
  EXPECT_EQ(out[6].name, "joint.elbow_joint.position");
  EXPECT_EQ(out[18].name, "safety.clamps");
  EXPECT_EQ(out[18].size, 12u);
  EXPECT_EQ(out[20].name, "links.frames");
  EXPECT_EQ(out[20].size, 7u * dca::sim::link_frames(d).size());
  EXPECT_EQ(dca::sim::joint_command_signals(d)[4].name, "joint.elbow_joint.position_command");
}

TEST(RobotDescriptionTest, Ur10KinematicsAreItsDenavitHartenbergParameters) {
  dca::sim::UrdfBodies bodies(kUr10);
  EXPECT_NEAR(bodies.total_mass(), 4.0 + 7.1 + 12.7 + 4.27 + 2.0 + 2.0 + 0.365, 1e-9);
  const std::vector<std::vector<double>> poses = {
      {0, 0, 0, 0, 0, 0}, {0.3, -1.2, 1.9, -0.4, 0.8, 2.5}, {-2.0, -0.3, -1.0, 1.5, -1.2, -0.7}};
  for (const auto& q : poses) {
    const auto names = bodies.joints();
    for (size_t i = 0; i < 6; ++i) bodies.set_q(names[i], {q[i]});
    const Eigen::Isometry3d got = bodies.link_pose("tool0"), want = ur10_dh(q);
    EXPECT_LT((got.matrix() - want.matrix()).cwiseAbs().maxCoeff(), 1e-9) << "q0 " << q[0] << "\n"
        << got.matrix() << "\nwant\n" << want.matrix();
  }
  // the arm stretched out at zero: x = a2 + a3, y = -(d4 + d6), z = d1 - d5
  for (const auto& n : bodies.joints()) bodies.set_q(n, {0});
  EXPECT_LT((bodies.link_pose("tool0").translation() - Eigen::Vector3d(-1.1843, -0.256141, 0.0116)).norm(), 1e-9);
}

TEST(RobotDescriptionTest, ManyJointsInAnUnusualStyleLoadWithTheDefaultEffortCommand) {
  const auto d = load_description(kSource + "/tests/sim/robots/centipede.urdf");
  EXPECT_FALSE(d.declared);  // an empty ros2_control: no joint declared
  ASSERT_EQ(d.joints.size(), 14u);
  for (const auto& j : d.joints) {
    ASSERT_EQ(j.commands.size(), 1u) << j.name;
    EXPECT_EQ(j.commands[0].kind, JointInterface::effort) << j.name;
  }
  EXPECT_TRUE(d.joint("jaw_right")->linear);
  EXPECT_EQ(d.joint("wheel_l")->limits.upper, INFINITY);  // continuous: no position bounds
  EXPECT_EQ(d.joint("wheel_l")->limits.effort, INFINITY);  // no <limit>: no effort bound
  EXPECT_EQ(d.joint("wheel_r")->limits.effort, 5);
  EXPECT_TRUE(d.joint("mast")->limits.soft);
  EXPECT_EQ(d.joint("mast")->limits.soft_upper, 0.29);
  EXPECT_EQ(d.joint("spine_1")->where, kSource + "/tests/sim/robots/centipede.urdf:14:3");
  EXPECT_EQ(dca::sim::joint_command_signals(d)[8].name, "joint.jaw_left.effort_command");
  EXPECT_EQ(dca::sim::joint_command_signals(d)[8].units, "N");
  // and Simbody takes it
  dca::sim::UrdfBodies bodies(kSource + "/tests/sim/robots/centipede.urdf");
  EXPECT_EQ(bodies.joints().size(), 14u);
}

const std::string kInertial =
    "<inertial><mass value=\"1\"/><inertia ixx=\"0.1\" ixy=\"0\" ixz=\"0\" iyy=\"0.1\" iyz=\"0\" izz=\"0.1\"/></inertial>";

std::string robot(const std::string& body) { return "<robot name=\"r\">\n" + body + "</robot>\n"; }
std::string link(const std::string& name) { return "  <link name=\"" + name + "\">" + kInertial + "</link>\n"; }
std::string joint(const std::string& name, const std::string& type, const std::string& parent,
                  const std::string& child) {
  return "  <joint name=\"" + name + "\" type=\"" + type + "\"><parent link=\"" + parent + "\"/><child link=\"" +
         child + "\"/><axis xyz=\"0 0 1\"/><limit lower=\"-1\" upper=\"1\" effort=\"10\" velocity=\"1\"/></joint>\n";
}

TEST(RobotDescriptionTest, BrokenFilesNameFileLineAndElement) {
  const std::string dir = temp().path() + "/";
  // a moving link without <inertial>: the link's line
  EXPECT_EQ(error_of("no_inertial.urdf", robot(link("a") + "  <link name=\"b\"/>\n" + joint("j", "revolute", "a", "b"))),
            dir + "no_inertial.urdf:3:3: link 'b': has no <inertial>, but joint 'j' (" + dir +
                "no_inertial.urdf:4:3) moves it: a moving link needs a mass");
  // an unsupported joint type
  EXPECT_EQ(error_of("type.urdf", robot(link("a") + link("b") + joint("screw", "helical", "a", "b"))),
            dir + "type.urdf:4:3: joint 'screw': type 'helical' is not supported (fixed, revolute, continuous, "
                  "prismatic, floating, planar)");
  // an unknown parent link
  EXPECT_EQ(error_of("parent.urdf", robot(link("a") + link("b") + joint("j", "revolute", "nowhere", "b"))),
            dir + "parent.urdf:4:3: joint 'j': its parent link 'nowhere' is not defined");
  // a kinematic loop: a link with two parents, and a cycle
  EXPECT_EQ(error_of("loop.urdf", robot(link("a") + link("b") + link("c") + joint("j1", "revolute", "a", "b") +
                                        joint("j2", "revolute", "b", "c") + joint("j3", "revolute", "a", "c"))),
            dir + "loop.urdf:7:3: joint 'j3': link 'c' is already the child of joint 'j2' (" + dir +
                "loop.urdf:6:3): a kinematic loop; URDF describes a tree");
  const std::string cycle = error_of("cycle.urdf", robot(link("a") + link("b") + link("c") + link("root") +
                                                         joint("j1", "revolute", "a", "b") +
                                                         joint("j2", "revolute", "b", "c") +
                                                         joint("j3", "revolute", "c", "a")));
  EXPECT_EQ(cycle.rfind(dir + "cycle.urdf:6:3: joint 'j1': a kinematic loop", 0), 0u) << cycle;
}

TEST(RobotDescriptionTest, TruncatedXmlSaysWhereItEnds) {
  const std::string whole = robot(link("a") + link("b") + joint("j", "revolute", "a", "b"));
  for (const size_t cut : {whole.size() / 3, whole.size() / 2, whole.size() - 4}) {
    const std::string e = error_of("truncated.urdf", whole.substr(0, cut));
    EXPECT_EQ(e.rfind(temp().path() + "/truncated.urdf:", 0), 0u) << e;
    EXPECT_NE(e.find(": not well-formed XML: "), std::string::npos) << e;
  }
  EXPECT_EQ(error_of("empty.urdf", ""), temp().path() + "/empty.urdf:1:1: not well-formed XML: Error document empty.");
}

TEST(RobotDescriptionTest, UrdfdomsOwnErrorsGetTheElementsLine) {
  const std::string e = error_of("limit.urdf", robot(link("a") + link("b") +
                                                     "  <joint name=\"j\" type=\"revolute\"><parent link=\"a\"/>"
                                                     "<child link=\"b\"/></joint>\n"));
  EXPECT_EQ(e.rfind(temp().path() + "/limit.urdf:4:3: joint 'j': not a valid URDF", 0), 0u) << e;
}

TEST(RobotDescriptionTest, Ros2ControlMistakesNameTheirLine) {
  const std::string base = link("a") + link("b") + joint("j", "revolute", "a", "b");
  const auto control = [&](const std::string& inside) {
    return robot(base + "  <ros2_control name=\"x\" type=\"system\">\n" + inside + "  </ros2_control>\n");
  };
  const std::string dir = temp().path() + "/";
  EXPECT_EQ(error_of("rc1.urdf", control("    <joint name=\"ghost\"/>\n")),
            dir + "rc1.urdf:6:5: ros2_control joint 'ghost': no revolute, continuous or prismatic joint of that name");
  EXPECT_EQ(error_of("rc2.urdf", control("    <joint name=\"j\">\n      <command_interface name=\"acceleration\"/>\n"
                                         "    </joint>\n")),
            dir + "rc2.urdf:7:7: ros2_control joint 'j': command interface 'acceleration' is not supported "
                  "(position, velocity, effort)");
  EXPECT_EQ(error_of("rc3.urdf", control("    <joint name=\"j\">\n      <command_interface name=\"velocity\"/>\n"
                                         "      <param name=\"watchdog_ticks\">soon</param>\n    </joint>\n")),
            dir + "rc3.urdf:8:7: ros2_control joint 'j': <param name=\"watchdog_ticks\">: 'soon' is not a number");
  const auto d = load_description(write("rc4.urdf", control(
      "    <joint name=\"j\">\n      <param name=\"watchdog_ticks\">7</param>\n"
      "      <command_interface name=\"effort\"><param name=\"on_stale\">hold</param><param name=\"max\">3</param>"
      "</command_interface>\n      <state_interface name=\"position\"><param name=\"initial_value\">0.25</param>"
      "</state_interface>\n    </joint>\n")));
  ASSERT_EQ(d.joints[0].commands.size(), 1u);
  EXPECT_EQ(d.joints[0].commands[0].watchdog_ticks, 7);
  EXPECT_EQ(d.joints[0].commands[0].on_stale, dca::sim::OnStale::hold);
  EXPECT_EQ(d.joints[0].commands[0].max, 3);
  EXPECT_EQ(d.joints[0].initial, 0.25);
}

TEST(RobotDescriptionTest, AMeshNotFoundIsAWarningNamingIt) {
  const std::string visual = "  <link name=\"m\">" + kInertial +
                             "<visual><geometry><mesh filename=\"package://arms/meshes/m.stl\"/></geometry></visual>"
                             "</link>\n";
  const std::string text = robot(link("a") + visual + joint("j", "revolute", "a", "m"));
  const std::string path = write("mesh.urdf", text);
  ::unsetenv("ROS_PACKAGE_PATH");
  ::setenv("DCA_PACKAGE_PATH", (temp().path() + "/nowhere").c_str(), 1);
  auto d = load_description(path);
  ASSERT_EQ(d.warnings.size(), 1u);
  const std::string column = std::to_string(visual.find("<mesh") + 1);
  EXPECT_EQ(d.warnings[0].rfind(path + ":3:" + column + ": mesh 'package://arms/meshes/m.stl' not found (package 'arms' searched in " +
                                    temp().path() + "/nowhere)", 0), 0u) << d.warnings[0];
  EXPECT_EQ(d.joints.size(), 1u);  // it loads all the same
  // found through the search path: no warning
  fs::create_directories(temp().path() + "/pkgs/arms/meshes");
  std::ofstream(temp().path() + "/pkgs/arms/meshes/m.stl") << "solid m\nendsolid m\n";
  ::setenv("DCA_PACKAGE_PATH", (temp().path() + "/nowhere:" + temp().path() + "/pkgs").c_str(), 1);
  d = load_description(path);
  EXPECT_TRUE(d.warnings.empty()) << d.warnings[0];
  ::unsetenv("DCA_PACKAGE_PATH");
  ::setenv("ROS_PACKAGE_PATH", (temp().path() + "/pkgs/arms").c_str(), 1);  // a package's own folder
  EXPECT_TRUE(load_description(path).warnings.empty());
  ::unsetenv("ROS_PACKAGE_PATH");
}

// A description with many joints that nobody here wrote: Rethink Robotics' Baxter as example-robot-data ships it
// (tests/sim/robots/README.md), meshes not copied. It loads through the generic loader: every moving joint with its
// state interfaces and the default effort command (no ros2_control tags), each mesh a warning naming it, and
// Simbody takes the tree.
TEST(RobotDescriptionTest, BaxterFromExampleRobotDataLoadsWithItsMeshesMissing) {
  const std::string path = kSource + "/tests/sim/robots/baxter.urdf";
  ::unsetenv("ROS_PACKAGE_PATH");
  ::setenv("DCA_PACKAGE_PATH", (temp().path() + "/nowhere").c_str(), 1);
  const auto d = load_description(path);
  ::unsetenv("DCA_PACKAGE_PATH");
  EXPECT_EQ(d.name, "baxter");
  EXPECT_FALSE(d.declared);
  ASSERT_EQ(d.joints.size(), 19u);  // head_pan, 2 x 7 arm joints, 2 x 2 gripper fingers
  std::size_t prismatic = 0;
  for (const auto& j : d.joints) {
    prismatic += j.linear;
    ASSERT_EQ(j.commands.size(), 1u) << j.name;
    EXPECT_EQ(j.commands[0].kind, JointInterface::effort) << j.name;
  }
  EXPECT_EQ(prismatic, 4u);
  EXPECT_EQ(d.joint("left_e1")->where, path + ":911:3");
  EXPECT_EQ(d.joint("right_s0")->limits.lower, -1.70167993878);
  // the state interfaces: position, velocity, effort of every moving joint
  std::size_t states = 0;
  for (const auto& s : dca::sim::joint_sensor_signals(d))
    if (s.name.rfind("joint.", 0) == 0) ++states;
  EXPECT_EQ(states, 3u * 19u);
  EXPECT_EQ(dca::sim::joint_command_signals(d).size(), 19u);
  // every mesh a warning naming it, none fatal
  EXPECT_EQ(d.warnings.size(), 30u);  // the file's 30 <mesh> elements (visual and collision)
  for (const auto& w : d.warnings)
    EXPECT_NE(w.find(": mesh 'package://example-robot-data/robots/baxter_description/meshes/"), std::string::npos) << w;
  EXPECT_EQ(d.warnings[0].rfind(path + ":", 0), 0u) << d.warnings[0];
  dca::sim::UrdfBodies bodies(path);
  EXPECT_EQ(bodies.joints().size(), 19u);
}

}  // namespace
