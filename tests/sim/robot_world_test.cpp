// The URDF worlds (sim/urdf/joint_world.h) at their ports: limits clamp and count, a stale command trips its
// watchdog at the declared step, the mock mirrors commands (with its lag, and dead drives), and the Simbody world
// servos a UR10 joint to its target against gravity.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include <urdf_model/model.h>

#include "sim/urdf/frames.h"
#include "sim/urdf/joint_world.h"
#include "tests/support/temp_dir.h"

namespace {

using dca::sim::JointWorld;
using dca::sim::RobotDescription;

const std::string kUr10 = std::string(DCA_SOURCE_DIR) + "/worlds/ur10/ur10.urdf";

// Sends `v` to the world's command input `name`.
void send(JointWorld& w, const std::string& name, double v) {
  const std::size_t i = dca::sim::signal_index(w.commands(), name);
  ASSERT_LT(i, w.commands().size()) << name;
  w.command(i, &v, 1);
}

double read(const JointWorld& w, const std::string& name, std::size_t k = 0) {
  const std::size_t i = dca::sim::signal_index(w.sensors(), name);
  EXPECT_LT(i, w.sensors().size()) << name;
  std::vector<double> v(w.sensors()[i].size);
  w.sensor(i, v.data());
  return v[k];
}

void steps(JointWorld& w, int n) {
  for (int i = 0; i < n; ++i) w.step();
}

std::size_t input(const JointWorld& w, const std::string& name) { return dca::sim::signal_index(w.commands(), name); }

// One revolute joint "j" with the ros2_control joint body `control` (interfaces, params).
std::string one_joint(const std::string& control, const std::string& limit = "lower=\"-1\" upper=\"1\" effort=\"10\" velocity=\"2\"") {
  static const dca::test::TempDir dir("robot_world_test");
  static int n = 0;
  const std::string path = dir.path() + "/one_" + std::to_string(++n) + ".urdf";
  std::ofstream(path)
      << "<robot name=\"one\">\n"
         "  <link name=\"base\"/>\n"
         "  <link name=\"arm\"><inertial><origin xyz=\"0.5 0 0\"/><mass value=\"1\"/>"
         "<inertia ixx=\"0.01\" ixy=\"0\" ixz=\"0\" iyy=\"0.01\" iyz=\"0\" izz=\"0.01\"/></inertial></link>\n"
         "  <joint name=\"j\" type=\"revolute\"><parent link=\"base\"/><child link=\"arm\"/><axis xyz=\"0 0 1\"/>"
         "<limit " << limit << "/></joint>\n"
         "  <ros2_control name=\"one\" type=\"system\"><joint name=\"j\">" << control << "</joint></ros2_control>\n"
         "</robot>\n";
  return path;
}

TEST(RobotWorldTest, JointLimitsClampEveryCommandAndCountIt) {
  auto w = dca::sim::make_robot_world("mock:" + kUr10, 1e-3);
  // the elbow's soft limit is pi - 0.05: a target beyond it goes there, counted once per sample
  send(*w, "joint.elbow_joint.position_command", 5.0);
  steps(*w, 10);
  EXPECT_NEAR(read(*w, "joint.elbow_joint.position"), M_PI - 0.05, 1e-12);
  const std::size_t elbow = input(*w, "joint.elbow_joint.position_command");
  EXPECT_EQ(w->interfaces().counts(elbow).clamped, 1u);
  send(*w, "joint.elbow_joint.position_command", -7.0);
  send(*w, "joint.elbow_joint.position_command", 1.0);  // the latest wins: within limits
  steps(*w, 1);
  EXPECT_EQ(w->interfaces().counts(elbow).clamped, 1u);
  EXPECT_EQ(w->interfaces().counts(elbow).samples, 3u);
  send(*w, "joint.elbow_joint.position_command", -7.0);
  steps(*w, 1);
  EXPECT_NEAR(read(*w, "joint.elbow_joint.position"), -(M_PI - 0.05), 1e-12);
  EXPECT_EQ(read(*w, "safety.clamps", elbow), 2.0);  // the counts are a port too (and so in the trace)
  // velocity: the data sheet's 120 deg/s on the shoulder
  send(*w, "joint.shoulder_pan_joint.velocity_command", 10.0);
  steps(*w, 1);
  EXPECT_NEAR(read(*w, "joint.shoulder_pan_joint.velocity"), 2.0944, 1e-9);
  EXPECT_EQ(w->interfaces().counts(input(*w, "joint.shoulder_pan_joint.velocity_command")).clamped, 1u);
  // a sample that is no number is dropped and counted; the command in force stays
  send(*w, "joint.shoulder_pan_joint.velocity_command", NAN);
  steps(*w, 1);
  EXPECT_NEAR(read(*w, "joint.shoulder_pan_joint.velocity"), 2.0944, 1e-9);
  EXPECT_EQ(w->interfaces().counts(input(*w, "joint.shoulder_pan_joint.velocity_command")).clamped, 2u);
  const auto lines = w->summary();
  ASSERT_FALSE(lines.empty());
  EXPECT_EQ(lines[0], "joint.shoulder_pan_joint.velocity_command: 2 of 2 samples clamped, stale 0 times");
}

TEST(RobotWorldTest, SoftLimitsSlowAVelocityCommandNearThem) {
  auto w = dca::sim::make_robot_world("mock:" + kUr10, 1e-3);
  send(*w, "joint.elbow_joint.position_command", M_PI - 0.1);  // 0.05 inside the soft limit
  steps(*w, 1);
  send(*w, "joint.elbow_joint.velocity_command", 1.0);
  steps(*w, 1);
  // k_position 20: at most 20 * 0.05 = 1 rad/s; allowed here exactly
  EXPECT_NEAR(read(*w, "joint.elbow_joint.velocity"), 1.0, 1e-9);
  for (int k = 0; k < 2000; ++k) {  // approaches the soft limit, never passes it (refreshed: no watchdog)
    if (k % 10 == 0) send(*w, "joint.elbow_joint.velocity_command", 1.0);
    w->step();
  }
  EXPECT_LE(read(*w, "joint.elbow_joint.position"), M_PI - 0.05 + 1e-12);
  EXPECT_GT(read(*w, "joint.elbow_joint.position"), M_PI - 0.05 - 1e-3);
}

TEST(RobotWorldTest, AStaleCommandTripsTheWatchdogAtTheDeclaredTick) {
  const std::string zero = one_joint(
      "<command_interface name=\"velocity\"/><param name=\"watchdog_ticks\">5</param>"
      "<param name=\"on_stale\">zero</param>");
  auto w = dca::sim::make_robot_world("mock:" + zero, 1e-3);
  send(*w, "joint.j.velocity_command", 1.0);
  for (int k = 0; k < 5; ++k) {  // steps 0-4 move at 1 rad/s
    w->step();
    EXPECT_NEAR(read(*w, "joint.j.velocity"), 1.0, 1e-12) << k;
  }
  EXPECT_EQ(w->interfaces().counts(0).stale, 0u);
  w->step();  // step 5: five steps without a sample
  EXPECT_EQ(read(*w, "joint.j.velocity"), 0.0);
  EXPECT_NEAR(read(*w, "joint.j.position"), 0.005, 1e-12);
  EXPECT_EQ(w->interfaces().counts(0).stale, 1u);
  EXPECT_EQ(w->interfaces().counts(0).first_stale_tick, 5);
  EXPECT_EQ(read(*w, "safety.stale"), 1.0);
  send(*w, "joint.j.velocity_command", 1.0);  // a fresh sample: moving again
  w->step();
  EXPECT_NEAR(read(*w, "joint.j.velocity"), 1.0, 1e-12);

  const std::string hold = one_joint(
      "<command_interface name=\"velocity\"><param name=\"watchdog_ticks\">3</param>"
      "<param name=\"on_stale\">hold</param></command_interface>");
  auto h = dca::sim::make_robot_world("mock:" + hold, 1e-3);
  send(*h, "joint.j.velocity_command", 0.5);
  steps(*h, 10);
  EXPECT_NEAR(read(*h, "joint.j.velocity"), 0.5, 1e-12);  // held
  EXPECT_EQ(h->interfaces().counts(0).stale, 1u);
  EXPECT_EQ(h->interfaces().counts(0).first_stale_tick, 3);
}

// The UR10's own declaration (worlds/ur10/ur10.urdf: watchdog_ticks 100, velocity commands zero when stale): a
// velocity command sent once drives steps 0-99, and step 100 trips the watchdog, on the mock hardware and in the
// Simbody world alike.
TEST(RobotWorldTest, Ur10VelocityCommandTripsItsWatchdogAtTheDeclaredTick) {
  for (const std::string& spec : {"mock:" + kUr10, kUr10}) {
    const bool mock = spec.rfind("mock:", 0) == 0;
    auto w = dca::sim::make_robot_world(spec, 1e-3);
    const std::size_t in = input(*w, "joint.wrist_1_joint.velocity_command");
    ASSERT_LT(in, w->commands().size());
    const int declared = w->interfaces().spec_of(in).watchdog_ticks;
    ASSERT_EQ(declared, 100) << "as worlds/ur10/ur10.urdf declares";
    const std::size_t joint = w->interfaces().joint_of(in);
    send(*w, "joint.wrist_1_joint.velocity_command", 0.5);
    for (int k = 0; k < declared; ++k) {
      w->step();
      ASSERT_EQ(w->interfaces().counts(in).stale, 0u) << spec << " step " << k;
      ASSERT_EQ(w->interfaces().drive(joint).value, 0.5) << spec << " step " << k;
    }
    if (mock) {
      EXPECT_NEAR(read(*w, "joint.wrist_1_joint.velocity"), 0.5, 1e-12);
    }
    w->step();  // step 100: a hundred steps without a sample
    EXPECT_EQ(w->interfaces().counts(in).stale, 1u) << spec;
    EXPECT_EQ(w->interfaces().counts(in).first_stale_tick, declared) << spec;
    EXPECT_EQ(w->interfaces().drive(joint).value, 0.0) << spec;
    EXPECT_EQ(read(*w, "safety.stale", in), 1.0) << spec;
    if (mock) {
      EXPECT_EQ(read(*w, "joint.wrist_1_joint.velocity"), 0.0);
    }
  }
}

TEST(RobotWorldTest, ALostWriterMakesItsCommandStaleAtOnce) {
  auto w = dca::sim::make_robot_world("mock:" + kUr10, 1e-3);
  send(*w, "joint.wrist_1_joint.velocity_command", 1.0);
  steps(*w, 2);
  w->writer_gone(input(*w, "joint.wrist_1_joint.velocity_command"));
  w->step();
  EXPECT_EQ(read(*w, "joint.wrist_1_joint.velocity"), 0.0);  // the UR10's velocity interfaces zero when stale
  EXPECT_EQ(w->interfaces().counts(input(*w, "joint.wrist_1_joint.velocity_command")).stale, 1u);
}

// The emergency stop (docs/safety.md): from the step after the press every actuator is at rest whatever was
// commanded (velocity zero, a position held where it was), and after the release each command keeps that safe
// value until its next sample.
TEST(RobotWorldTest, AnEmergencyStopHoldsEveryActuatorStoppedUntilItsRelease) {
  auto w = dca::sim::make_robot_world("mock:" + kUr10, 1e-3);
  send(*w, "joint.wrist_1_joint.velocity_command", 1.0);
  send(*w, "joint.elbow_joint.position_command", 0.5);
  steps(*w, 3);
  EXPECT_EQ(read(*w, "joint.wrist_1_joint.velocity"), 1.0);
  const double q_wrist = read(*w, "joint.wrist_1_joint.position");
  w->estop(true);
  w->step();
  EXPECT_EQ(read(*w, "joint.wrist_1_joint.velocity"), 0.0);
  EXPECT_EQ(read(*w, "joint.wrist_1_joint.position"), q_wrist);
  EXPECT_EQ(read(*w, "joint.elbow_joint.position"), 0.5);
  EXPECT_EQ(read(*w, "joint.elbow_joint.velocity"), 0.0);
  steps(*w, 10);
  EXPECT_EQ(read(*w, "joint.wrist_1_joint.position"), q_wrist);
  w->estop(false);
  w->step();  // released: still at rest, until a new sample
  EXPECT_EQ(read(*w, "joint.wrist_1_joint.velocity"), 0.0);
  EXPECT_EQ(read(*w, "joint.elbow_joint.position"), 0.5);
  send(*w, "joint.wrist_1_joint.velocity_command", -1.0);
  w->step();
  EXPECT_EQ(read(*w, "joint.wrist_1_joint.velocity"), -1.0);
  EXPECT_EQ(w->interfaces().counts(input(*w, "joint.wrist_1_joint.velocity_command")).stale, 0u);
}

// The same in the Simbody world: from the step after the press its servos' commands in force are the stopped
// ones (velocity zero, the position where the joint was), whatever was commanded; the wrist comes to rest.
TEST(RobotWorldTest, AnEmergencyStopDrivesTheSimbodyServosToRest) {
  auto w = dca::sim::make_robot_world(kUr10, 1e-3);
  send(*w, "joint.wrist_1_joint.velocity_command", 1.0);
  send(*w, "joint.elbow_joint.position_command", 1.0);
  steps(*w, 50);
  const std::size_t wrist = 3, elbow = 2;  // the UR10's joints in URDF order
  ASSERT_EQ(w->description().joints[wrist].name, "wrist_1_joint");
  ASSERT_EQ(w->description().joints[elbow].name, "elbow_joint");
  const double q_elbow = read(*w, "joint.elbow_joint.position");
  EXPECT_GT(read(*w, "joint.wrist_1_joint.velocity"), 0.3);  // moving at the press
  w->estop(true);
  w->step();
  EXPECT_EQ(w->interfaces().drive(wrist).value, 0.0);
  EXPECT_EQ(w->interfaces().drive(elbow).value, q_elbow);
  steps(*w, 300);
  EXPECT_LT(std::abs(read(*w, "joint.wrist_1_joint.velocity")), 0.01);  // at rest within 0.3 s
}

TEST(RobotWorldTest, MockMirrorsCommandsThroughItsLagAndIgnoresDeadDrives) {
  auto w = dca::sim::make_robot_world("mock:" + kUr10, 1e-3);
  send(*w, "joint.wrist_2_joint.position_command", 0.3);
  w->step();
  EXPECT_EQ(read(*w, "joint.wrist_2_joint.position"), 0.3);
  EXPECT_NEAR(read(*w, "joint.wrist_2_joint.velocity"), (0.3 + M_PI / 2) / 1e-3, 1e-6);

  auto lag = dca::sim::make_robot_world("mock:" + kUr10 + "?lag=0.1&dead=elbow_joint", 1e-3);
  send(*lag, "joint.wrist_2_joint.position_command", 0.3);
  send(*lag, "joint.elbow_joint.position_command", 0.3);
  lag->step();
  const double alpha = 1 - std::exp(-1e-3 / 0.1), q0 = -M_PI / 2;
  EXPECT_NEAR(read(*lag, "joint.wrist_2_joint.position"), q0 + alpha * (0.3 - q0), 1e-12);
  steps(*lag, 999);  // ten time constants
  EXPECT_NEAR(read(*lag, "joint.wrist_2_joint.position"), 0.3, 1e-4 * 0.3 + (0.3 - q0) * std::exp(-10.0));
  EXPECT_NEAR(read(*lag, "joint.elbow_joint.position"), M_PI / 2, 1e-12);  // dead: where it started
  EXPECT_EQ(lag->interfaces().counts(input(*lag, "joint.elbow_joint.position_command")).samples, 1u);
  const auto lines = lag->summary();
  EXPECT_EQ(lines.back(), "mock: dead drives (commands ignored): elbow_joint");
}

TEST(RobotWorldTest, BadWorldSpecsAreRefused) {
  EXPECT_THROW(dca::sim::make_robot_world("mock:" + kUr10 + "?dead=nose_joint", 1e-3), std::invalid_argument);
  EXPECT_THROW(dca::sim::make_robot_world("mock:" + kUr10 + "?lag=-1", 1e-3), std::invalid_argument);
  EXPECT_THROW(dca::sim::make_robot_world(kUr10 + "?lag=1", 1e-3), std::invalid_argument);
  EXPECT_THROW(dca::sim::make_robot_world("/nonexistent/r.urdf", 1e-3), dca::sim::UrdfError);
  EXPECT_TRUE(dca::sim::is_robot_world("mock:a.urdf?lag=1"));
  EXPECT_TRUE(dca::sim::is_robot_world("robots/a.urdf"));
  EXPECT_FALSE(dca::sim::is_robot_world("door"));
}

TEST(RobotWorldTest, SimbodyUr10HoldsItsPoseAndServosAJointToItsTarget) {
  auto w = dca::sim::make_robot_world(kUr10, 1e-3);
  steps(*w, 500);  // no command: the position servos hold the initial pose against gravity
  for (std::size_t j = 0; j < 6; ++j)
    EXPECT_NEAR(w->state()[j].position, w->description().joints[j].initial, 1e-2) << j;
  EXPECT_LT(read(*w, "joint.shoulder_lift_joint.effort"), -10.0);  // holding the forearm up
  for (int k = 0; k < 3000; ++k) {  // a controller at 100 Hz: the target every 10 steps
    if (k % 10 == 0) send(*w, "joint.elbow_joint.position_command", 1.0);
    w->step();
  }
  EXPECT_NEAR(read(*w, "joint.elbow_joint.position"), 1.0, 2e-3);
  EXPECT_NEAR(read(*w, "joint.elbow_joint.velocity"), 0.0, 1e-2);
  for (const char* j : {"shoulder_pan_joint", "shoulder_lift_joint", "wrist_1_joint", "wrist_2_joint"})
    EXPECT_NEAR(read(*w, std::string("joint.") + j + ".position"), w->description().joint(j)->initial, 2e-3) << j;
  EXPECT_EQ(read(*w, "safety.clamps", input(*w, "joint.elbow_joint.position_command")), 0.0);
}

TEST(RobotWorldTest, SimbodyEffortDefaultLetsAPendulumSwing) {
  const std::string path = one_joint("", "lower=\"-3\" upper=\"3\" effort=\"10\" velocity=\"20\"");
  // no command interface declared for "j" (an empty ros2_control joint): passive
  auto w = dca::sim::make_robot_world(path, 1e-3);
  EXPECT_TRUE(w->commands().empty());
  steps(*w, 100);
  EXPECT_EQ(read(*w, "joint.j.position"), 0.0);  // its axis is vertical: gravity does not turn it
}

}  // namespace

// The link frames (sim/urdf/frames.h): one per link, the root in "world", every other link in its parent link;
// the Simbody world's (from its bodies' transforms) equal the forward kinematics of the URDF at the same joint
// positions (the mock's), after the elbow moved.
TEST(RobotWorldTest, LinkFramesOfTheSimbodyWorldAreTheUrdfsForwardKinematics) {
  auto w = dca::sim::make_robot_world(kUr10, 1e-3);
  const auto& frames = w->frames();
  ASSERT_EQ(frames.size(), w->description().urdf.model->links_.size());
  EXPECT_EQ(frames[0].parent, "world");
  EXPECT_EQ(frames[0].child, w->description().urdf.model->getRoot()->name);
  const std::size_t port = dca::sim::signal_index(w->sensors(), "links.frames");
  ASSERT_LT(port, w->sensors().size());
  ASSERT_EQ(w->sensors()[port].size, 7 * frames.size());
  for (int k = 0; k < 300; ++k) {
    if (k % 10 == 0) send(*w, "joint.elbow_joint.position_command", 0.5);
    w->step();
  }
  std::vector<double> bodies(7 * frames.size()), fk(7 * frames.size()), q;
  w->sensor(port, bodies.data());
  for (const auto& s : w->state()) q.push_back(s.position);
  dca::sim::joint_frames(w->description(), q, fk.data());
  for (std::size_t i = 0; i < fk.size(); ++i) {
    const std::size_t f = i / 7, k = i % 7;
    const double sign = bodies[7 * f + 6] * fk[7 * f + 6] < 0 ? -1 : 1;  // q and -q are one rotation
    EXPECT_NEAR(bodies[i], (k >= 3 ? sign : 1) * fk[i], 1e-6) << frames[f].parent << " -> " << frames[f].child << " [" << k << "]";
  }
  auto mock = dca::sim::make_robot_world("mock:" + kUr10, 1e-3);
  EXPECT_EQ(mock->frames().size(), frames.size());
}
