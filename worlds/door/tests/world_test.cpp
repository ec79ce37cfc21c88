// Physics sanity of the door world, stepped in lock-step by the test itself (deterministic).
#include "worlds/door/world.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdlib>

#include "worlds/door/door_script.h"

namespace {

using dca::sim::Commands;
using dca::sim::GripperState;
using dca::sim::World;

class WorldTest : public ::testing::Test {
 protected:
  static void run(World& w, double seconds) {
    const int n = static_cast<int>(std::lround(seconds / w.config().period));
    for (int i = 0; i < n; ++i) w.step();
  }
};

TEST_F(WorldTest, ArmHeldStillByJointPd) {
  World w(dca::sim::door_world());
  const auto q0 = w.sensors().arm_q;
  const auto base0 = w.sensors().base_pose;
  run(w, 2.0);
  for (size_t i = 0; i < 6; ++i) {
    EXPECT_NEAR(w.sensors().arm_q[i], q0[i], 1e-4) << "joint " << i + 1;
    EXPECT_NEAR(w.sensors().arm_qd[i], 0.0, 1e-4) << "joint " << i + 1;
  }
  EXPECT_NEAR(w.sensors().base_pose.x, base0.x, 1e-6);
  EXPECT_NEAR(w.sensors().base_pose.y, base0.y, 1e-6);
  EXPECT_NEAR(w.time(), 2.0, 1e-9);
}

TEST_F(WorldTest, ArmFollowsCommandedJointRates) {
  World w(dca::sim::door_world());
  const auto q0 = w.sensors().arm_q;
  Commands c;
  c.arm_qd = {0.1, -0.05, 0.08, 0.2, -0.1, 0.3};
  w.set_commands(c);
  run(w, 1.0);
  for (size_t i = 0; i < 6; ++i) {
    EXPECT_NEAR(w.sensors().arm_qd[i], c.arm_qd[i], 1e-3) << "joint " << i + 1;
    EXPECT_NEAR(w.sensors().arm_q[i], q0[i] + c.arm_qd[i] * 1.0, 5e-3) << "joint " << i + 1;
  }
}

TEST_F(WorldTest, BaseFollowsCommandedVelocity) {
  World w(dca::sim::door_world());
  Commands c;
  const double vx = 0.2, vy = 0.1, wz = 0.3, T = 3.0;
  c.base_vel = {vx, vy, wz};
  w.set_commands(c);
  run(w, T);
  const auto& s = w.sensors();
  EXPECT_NEAR(s.base_vel[0], vx, 1e-3);
  EXPECT_NEAR(s.base_vel[1], vy, 1e-3);
  EXPECT_NEAR(s.base_vel[2], wz, 1e-3);
  // Constant body-frame velocity: an arc. Integrate R(wz t) v from 0 to T.
  const double a = wz * T;
  const double x = (vx * std::sin(a) + vy * (std::cos(a) - 1)) / wz;
  const double y = (vx * (1 - std::cos(a)) + vy * std::sin(a)) / wz;
  EXPECT_NEAR(s.base_pose.x, x, 5e-3);
  EXPECT_NEAR(s.base_pose.y, y, 5e-3);
  EXPECT_NEAR(s.base_pose.yaw, a, 5e-3);
  // The laser follows the base: its beam (yawed by a) to the plane x = 2 from the laser at 0.3 m ahead.
  const double lx = s.base_pose.x + 0.3 * std::cos(s.base_pose.yaw);
  EXPECT_NEAR(s.laser_range, (2.0 - lx) / std::cos(s.base_pose.yaw), 1e-9);
}

TEST_F(WorldTest, HandleSpringsBackWhenReleased) {
  auto config = dca::sim::door_world();
  config.handle_start = 0.6;
  World w(config);
  run(w, 0.01);
  EXPECT_GT(w.sensors().handle_angle, 0.5);
  run(w, 1.0);
  EXPECT_NEAR(w.sensors().handle_angle, 0.0, 0.01);  // resting against its stop, pushed by the preload
  EXPECT_TRUE(w.latched());
}

TEST_F(WorldTest, DoorStaysShutWhileLatched) {
  World w(dca::sim::door_world());
  w.set_disturbance(30.0, 0.0);  // a firm push on the leaf
  run(w, 2.0);
  EXPECT_TRUE(w.latched());
  EXPECT_GT(w.sensors().door_angle, 0.0);
  EXPECT_LT(w.sensors().door_angle, w.config().door.latch_play + 0.01);
}

TEST_F(WorldTest, DoorOpensWhenPushedAfterTheHandleIsPressed) {
  World w(dca::sim::door_world());
  w.set_disturbance(0.0, 1.5);  // press the handle (1.5 N m beats the spring up to its stop)
  run(w, 0.5);
  EXPECT_GT(w.sensors().handle_angle, w.config().door.latch_release);
  EXPECT_FALSE(w.latched());
  w.set_disturbance(10.0, 1.5);
  run(w, 2.0);
  EXPECT_GT(w.sensors().door_angle, 0.5);
  // Released, the handle springs back; the open door does not re-latch until it is shut.
  w.set_disturbance(0.0, 0.0);
  run(w, 1.0);
  EXPECT_NEAR(w.sensors().handle_angle, 0.0, 0.01);
  EXPECT_FALSE(w.latched());
}

TEST_F(WorldTest, JammedLatchNeverReleases) {
  auto config = dca::sim::door_world();
  config.door.latch_jammed = true;
  World w(config);
  w.set_disturbance(30.0, 1.5);
  run(w, 2.0);
  EXPECT_GT(w.sensors().handle_angle, w.config().door.latch_release);
  EXPECT_TRUE(w.latched());
  EXPECT_LT(w.sensors().door_angle, w.config().door.latch_play + 0.01);
}

TEST_F(WorldTest, WrenchReadsTheToolsWeightWhenStill) {
  World w(dca::sim::door_world());
  run(w, 0.5);
  const double tool_mass = 0.25 + 0.6 + 0.05 + 0.05;  // sensor's tool side, palm, fingers
  const Eigen::Matrix3d R_GS = w.link_pose("ft_sensor").linear();
  const Eigen::Vector3d expected = R_GS.transpose() * Eigen::Vector3d(0, 0, -9.81 * tool_mass);
  const auto& f = w.sensors().wrench;
  EXPECT_NEAR(f[0], expected.x(), 1e-3);
  EXPECT_NEAR(f[1], expected.y(), 1e-3);
  EXPECT_NEAR(f[2], expected.z(), 1e-3);
  EXPECT_NEAR(std::hypot(f[0], f[1], f[2]), 9.81 * tool_mass, 1e-3);
}

TEST_F(WorldTest, CameraSeesTheHandleWherePinholeGeometrySays) {
  World w(dca::sim::door_world());
  const auto& cam = w.sensors().camera_handle;
  ASSERT_EQ(cam[2], 1.0);
  // The camera: on the mast at (0.25, 0, 1.35), pitched 10 degrees down; the grasp point on the door.
  const Eigen::Matrix3d R = Eigen::AngleAxisd(10 * M_PI / 180, Eigen::Vector3d::UnitY()).toRotationMatrix();
  const Eigen::Vector3d p = R.transpose() * (w.link_pose("door_grasp").translation() - Eigen::Vector3d(0.25, 0, 1.35));
  const double f = 320 / std::tan(30 * M_PI / 180);
  EXPECT_NEAR(cam[0], 320 - f * p.y() / p.x(), 1e-6);
  EXPECT_NEAR(cam[1], 240 - f * p.z() / p.x(), 1e-6);
  EXPECT_NEAR(w.sensors().laser_range, 1.7, 1e-9);
  // Turned away, the handle leaves the image and the laser misses the wall.
  Commands c;
  c.base_vel = {0, 0, 1.0};
  w.set_commands(c);
  run(w, 2.0);
  EXPECT_EQ(w.sensors().camera_handle[2], 0.0);
  EXPECT_EQ(w.sensors().laser_range, w.config().laser_max_range);
}

TEST_F(WorldTest, ClosingOnNothingGraspsNothing) {
  World w(dca::sim::door_world());
  EXPECT_EQ(w.sensors().gripper, GripperState::open);
  EXPECT_NEAR(w.sensors().gripper_width, 0.088, 1e-3);
  Commands c;
  c.gripper_close = true;
  w.set_commands(c);
  run(w, 0.1);
  EXPECT_EQ(w.sensors().gripper, GripperState::moving);
  run(w, 1.5);
  EXPECT_EQ(w.sensors().gripper, GripperState::closed);
  EXPECT_NEAR(w.sensors().gripper_width, 0.0, 2e-3);
  EXPECT_FALSE(w.grasping());
  c.gripper_close = false;
  w.set_commands(c);
  run(w, 1.5);
  EXPECT_EQ(w.sensors().gripper, GripperState::open);
}

TEST_F(WorldTest, SeedsGiveReproducibleWorldsWithinTheirBounds) {
  for (std::uint64_t seed = 1; seed <= 10; ++seed) {
    const auto a = dca::sim::door_world(seed), b = dca::sim::door_world(seed);
    EXPECT_EQ(a.base_start.x, b.base_start.x);
    EXPECT_EQ(a.door.width, b.door.width);
    EXPECT_LE(std::abs(a.base_start.x), 0.3);
    EXPECT_LE(std::abs(a.base_start.y), 0.3);
    EXPECT_LE(std::abs(a.base_start.yaw), 15 * M_PI / 180 + 1e-12);
    EXPECT_GE(a.door.width, 0.8);
    EXPECT_LE(a.door.width, 1.0);
    // The handle stays at y = 0 whatever the width.
    EXPECT_NEAR(a.door_pose.y + a.door.width - a.door.handle_backset, 0.0, 1e-12);
  }
  EXPECT_NE(dca::sim::door_world(1).door.width, dca::sim::door_world(2).door.width);
  EXPECT_EQ(dca::sim::door_world(3, 0.85).door.width, 0.85);
}

TEST_F(WorldTest, SameCommandsGiveTheSameRun) {
  const auto once = [] {
    World w(dca::sim::door_world(7));
    dca::sim::ScriptedDoorOpening script;
    for (int i = 0; i < 3000; ++i) {
      w.set_commands(script.update(w));
      w.step();
    }
    return w.sensors();
  };
  const auto a = once(), b = once();
  EXPECT_EQ(a.arm_q, b.arm_q);
  EXPECT_EQ(a.wrench, b.wrench);
  EXPECT_EQ(a.base_pose.x, b.base_pose.x);
  EXPECT_NE(a.base_pose.x, dca::sim::door_world(7).base_start.x);  // it moved
}

TEST_F(WorldTest, ScriptedOpenLoopRunGraspsPressesAndSwingsTheDoor) {
  World w(dca::sim::door_world());
  dca::sim::ScriptedDoorOpening script;
  bool grasped = false;
  double max_handle = 0;
  while (w.time() < 60 && script.phase() != dca::sim::DoorPhase::done &&
         script.phase() != dca::sim::DoorPhase::failed) {
    w.set_commands(script.update(w));
    w.step();
    grasped = grasped || w.grasping();
    max_handle = std::max(max_handle, w.sensors().handle_angle);
  }
  ASSERT_EQ(script.phase(), dca::sim::DoorPhase::done) << script.failure();
  EXPECT_TRUE(grasped);
  EXPECT_TRUE(w.grasping());
  EXPECT_GT(max_handle, w.config().door.latch_release);
  EXPECT_GT(w.sensors().door_angle, 60 * M_PI / 180);
  // The phases ran in order.
  double last = -1;
  for (auto p : {dca::sim::DoorPhase::drive, dca::sim::DoorPhase::pregrasp, dca::sim::DoorPhase::approach,
                 dca::sim::DoorPhase::close, dca::sim::DoorPhase::press, dca::sim::DoorPhase::push,
                 dca::sim::DoorPhase::done}) {
    EXPECT_GT(script.phase_start(p), last) << dca::sim::to_string(p);
    last = script.phase_start(p);
  }
}

}  // namespace

namespace {

TEST_F(WorldTest, VisualizerWithoutADisplaySaysWhyAndTheWorldRunsOn) {
  unsetenv("DISPLAY");
  World w(dca::sim::door_world());
  std::string error;
  EXPECT_FALSE(w.start_visualizer(&error));
  EXPECT_EQ(error, "no display (DISPLAY is not set)");
  run(w, 0.01);
  EXPECT_NEAR(w.time(), 0.01, 1e-12);
}

}  // namespace
