// The robot's controllers on simulated time (controllers/robot/): its geometry from the URDF, the drives'
// held commands, the gripper; their inputs fed by a test source and their outputs read back.
#include <gtest/gtest.h>

#include "controllers/robot/model.h"
#include <dca/robot/signals.h>
#include "tests/support/controller_fixture.h"

namespace {

using dca::robot::Vec3;
using dca::robot::Vec6;

class RobotTest : public dca::testing::ControllerFixture {
 protected:
  /// A started XR4000Ctrl with `params`, its Vel fed by the test source (Command).
  dca::Controller& StartBaseDrive(std::vector<std::string> params) {
    auto& xr = start("XR4000Ctrl", std::move(params), "/xr", {{"V", 3, "Vel"}});
    vel_ = &source("V");
    return xr;
  }
  /// Sends the base drive a command: forward at `vx`, turning at 0.1 rad/s.
  void Command(double vx) { vel_->write((Vec3() << vx, 0, 0.1).finished()); }
  /// The drive's Cmd after tick `k`.
  Eigen::VectorXd CmdAt(const dca::Controller& xr, int k) {
    timers.advance_to(k * kTick);
    return latest(xr, "Cmd");
  }

 private:
  dca::Output* vel_ = nullptr;
};

TEST_F(RobotTest, HardwareFacingPortsNameTheirRobotSignals) {
  const auto* m = dca::Registry::global().manifest("Puma560Ctrl");
  ASSERT_NE(m, nullptr);
  EXPECT_EQ(m->inputs[1].device, "arm.q");
  EXPECT_EQ(m->outputs[0].device, "arm.cmd_qd");
  EXPECT_EQ(m->outputs[1].device, "");
  EXPECT_EQ(dca::Registry::global().manifest("ForceTorque")->inputs[0].device, "wrist.wrench");
  EXPECT_EQ(dca::Registry::global().manifest("GripperControl")->outputs[0].device, "gripper.cmd");
}

TEST_F(RobotTest, RobotArmIsTheUrdfChainToTool0) {
  const auto arm = dca::robot::arm();
  EXPECT_EQ(arm.dof(), 6);
  EXPECT_EQ(arm.joint_names().front(), "arm_joint_1");
  EXPECT_EQ(arm.joint_names().back(), "arm_joint_6");
}

TEST_F(RobotTest, StaleCommandsStopTheRobotWithinOnePeriod) {
  auto& xr = StartBaseDrive({});  // period 10 ms, hold 10 ms
  Command(0.2);
  EXPECT_DOUBLE_EQ(CmdAt(xr, 1)[0], 0.2);
  EXPECT_TRUE(CmdAt(xr, 2).isZero());  // no new command: zero
  Command(0.2);
  EXPECT_DOUBLE_EQ(CmdAt(xr, 3)[0], 0.2);
  xr.halt();
  EXPECT_TRUE(latest(xr, "Cmd").isZero());
}

TEST_F(RobotTest, ADriveHoldsItsCommandForHoldThenStopsTheRobot) {
  auto& xr = StartBaseDrive({"0.01", "0.03"});  // period 10 ms, hold 30 ms
  Command(0.2);
  EXPECT_DOUBLE_EQ(CmdAt(xr, 1)[0], 0.2);
  EXPECT_DOUBLE_EQ(CmdAt(xr, 3)[0], 0.2);  // 20 ms old: still held
  EXPECT_TRUE(CmdAt(xr, 4).isZero());      // 30 ms old: zero
  Command(0.3);
  EXPECT_DOUBLE_EQ(CmdAt(xr, 6)[0], 0.3);
  xr.halt();
  EXPECT_TRUE(latest(xr, "Cmd").isZero());
}

TEST_F(RobotTest, ADriveFasterThanItsSourceHoldsTheCommandBetweenSamples) {
  // MotionControl at 1 ms fed by a 10 ms source: every tick commands the last sample, none is zero
  auto& puma = start("Puma560Ctrl", {"0.001"}, "/puma", {{"V", 6, "Vel"}});
  auto& v = source("V");
  for (int k = 0; k < 30; ++k) {
    if (k % 10 == 0) v.write((Vec6() << 0.1, 0, 0, 0, 0, 0).finished());
    timers.advance_to((k + 1) * kMs);
    EXPECT_DOUBLE_EQ(latest(puma, "Cmd")[0], 0.1) << "tick " << k;
  }
  timers.advance_to(40 * kMs);  // the last sample (at 21 ms) held until it is 10 ms old
  EXPECT_TRUE(latest(puma, "Cmd").isZero());
}

TEST_F(RobotTest, GripperCloseIsDoneWhenGraspingAndAbortsOnNothing) {
  auto& g = start("GripperControl", {"close"}, "/g", {{"S", 1, "State"}});
  auto& s = source("S");
  EXPECT_DOUBLE_EQ(latest(g, "Cmd")[0], 1.0);
  s.write((Eigen::VectorXd(1) << 2).finished());
  timers.advance_to(1 * kTick);
  EXPECT_TRUE(events.empty());
  s.write((Eigen::VectorXd(1) << 3).finished());
  timers.advance_to(2 * kTick);
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(unpack_string(events[0].second.value), "grasping");

  auto& g2 = make("GripperControl", {"close"}, "/g2");
  auto& s2 = feed("S2", 1, "/g2", "State");
  ASSERT_EQ(started(g2), "");
  s2.write((Eigen::VectorXd(1) << 1).finished());
  timers.advance_to(3 * kTick);
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[1].second.reason, "the gripper closed on nothing: no handle between the fingers");
}

TEST_F(RobotTest, GripperRefusesAnUnknownAction) {
  EXPECT_EQ(make_error("GripperControl", {"squeeze"}, "/g"),
            "GripperControl /g: parameter 'action' must be open or close, got 'squeeze'");
}

}  // namespace
