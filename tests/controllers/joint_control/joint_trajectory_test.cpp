// JointTrajectory alone (dca/testing/controller.h) on mock joints (joint_plant.h), on a simulated clock.
#include <dca/testing/controller.h>

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>
#include <vector>

#include "joint_plant.h"

namespace {

using dca::Controller;
using dca::joint_control::testing::Drive;
using dca::joint_control::testing::Joints;
using dca::testing::ControllerUnderTest;

// Two joints, three waypoints (a time, then two positions): a pause at the second, back to the start at the last.
const std::vector<std::string> kPlan = {"1.0", "0.5", "-0.4", "1.5", "0.5", "-0.4", "3.0", "0.1", "0.2"};
const Eigen::Vector2d kWaypoints[] = {{0.5, -0.4}, {0.5, -0.4}, {0.1, 0.2}};

std::vector<std::string> args(std::vector<std::string> head, const std::vector<std::string>& tail = kPlan) {
  head.insert(head.end(), tail.begin(), tail.end());
  return head;
}

// Ticks until the run ends or `limit` ticks passed; at each new waypoint reached, where the joints were.
std::vector<Eigen::VectorXd> run(Joints& j, int limit = 2000) {
  std::vector<Eigen::VectorXd> at;
  for (int k = 0; k < limit && j.c.state() == Controller::State::Running; ++k) {
    j.tick();
    while (static_cast<double>(at.size()) < j.c.get("Reached")) at.push_back(j.q);
  }
  return at;
}

// Each waypoint was reached, in order, within the tolerance 0.01.
void expect_reached(const std::vector<Eigen::VectorXd>& at) {
  ASSERT_EQ(at.size(), 3u);
  for (std::size_t k = 0; k < at.size(); ++k)
    EXPECT_LE((at[k] - kWaypoints[k]).cwiseAbs().maxCoeff(), 0.01) << "waypoint " << k + 1;
}

TEST(JointTrajectory, ReachesEachWaypointWithinToleranceThenEndsDone) {
  ControllerUnderTest c("JointTrajectory", args({"a b", "0.01", "position", "2", "60", "0.01"}));
  Joints j{c, Eigen::Vector2d(0.1, 0.2), Eigen::Vector2d::Zero(), Drive::Position, 0.05};
  c.start();
  expect_reached(run(j));
  ASSERT_TRUE(c.ended().has_value());
  EXPECT_TRUE(c.ended()->done) << c.ended()->reason;
  EXPECT_GE(c.ended()->number(), 3.0) << "the seconds it took: at least the last waypoint's time";
  EXPECT_LT(c.ended()->number(), 4.0);
  EXPECT_EQ(c.get("Reached"), 3.0);
}

TEST(JointTrajectory, TheSetpointFollowsAMinimumJerkCurveAtRestAtEachWaypoint) {
  ControllerUnderTest c("JointTrajectory", args({"a b", "0.01", "position", "2", "60", "0.01"}));
  Joints j{c, Eigen::Vector2d(0.1, 0.2), Eigen::Vector2d::Zero()};
  c.start();
  j.tick();  // the first tick: the setpoint starts where the joints are
  EXPECT_NEAR(c.get_vector("Setpoint")(0), 0.1, 1e-12);
  for (int k = 0; k < 50; ++k) j.tick();  // half way through the first segment (1 s): half way there
  EXPECT_NEAR(c.get_vector("Setpoint")(0), 0.3, 1e-9);
  EXPECT_NEAR(c.get_vector("Setpoint")(1), -0.1, 1e-9);
  for (int k = 0; k < 5; ++k) j.tick();  // the mock follows the position command at once
  EXPECT_NEAR(c.get_vector("Cmd1")(0), j.q(0), 1e-12);
  EXPECT_EQ(c.writes("Cmd3"), 0u) << "a slot past the joints is never written";
}

TEST(JointTrajectory, WaitsAtAWaypointUntilTheJointsAreThere) {
  // a slow joint (a lag of 0.5 s): each segment starts only once the last waypoint is reached
  ControllerUnderTest c("JointTrajectory", args({"a b", "0.01", "position", "2", "60", "0.01"}));
  Joints j{c, Eigen::Vector2d(0.1, 0.2), Eigen::Vector2d::Zero(), Drive::Position, 0.5};
  c.start();
  expect_reached(run(j));
  ASSERT_TRUE(c.ended() && c.ended()->done);
  EXPECT_GT(c.ended()->number(), 4.0) << "later than the plan's 3 s: it waited";
}

TEST(JointTrajectory, AJointThatDoesNotMoveEndsItAbortedNamingTheJointAndTheWaypoint) {
  ControllerUnderTest c("JointTrajectory", args({"a b", "0.01", "position", "2", "2", "0.01"}));
  Joints j{c, Eigen::Vector2d(0.1, 0.2), Eigen::Vector2d::Zero()};
  j.dead = 1;
  c.start();
  run(j);
  ASSERT_TRUE(c.ended().has_value());
  EXPECT_FALSE(c.ended()->done);
  EXPECT_EQ(c.ended()->reason, "waypoint 1 of 3 not reached within 2 s: joint b at 0.2000, wanted -0.4 (tolerance 0.01)");
  EXPECT_EQ(c.get("Reached"), 0.0);
}

TEST(JointTrajectory, ThroughTheVelocityCommandItEndsDoneAndHaltWritesZero) {
  ControllerUnderTest c("JointTrajectory", args({"a,b", "0.01", "velocity", "5", "60", "0.01"}));
  Joints j{c, Eigen::Vector2d(0.1, 0.2), Eigen::Vector2d::Zero(), Drive::Velocity};
  c.start();
  j.tick();
  j.tick();
  EXPECT_NE(c.get_vector("Cmd1")(0), 0.0);
  expect_reached(run(j));
  ASSERT_TRUE(c.ended() && c.ended()->done);
  EXPECT_EQ(c.get_vector("Cmd1")(0), 0.0) << "the end halts it: a velocity command is left zero";
  EXPECT_EQ(c.get_vector("Cmd2")(0), 0.0);
}

TEST(JointTrajectory, WaypointsFromTheInputReplaceTheHoldFromWhereTheSetpointIs) {
  ControllerUnderTest c("JointTrajectory", {"a b", "0.01", "position", "2", "60", "0.01"});
  Joints j{c, Eigen::Vector2d(0.1, 0.2), Eigen::Vector2d::Zero()};
  c.start();
  for (int k = 0; k < 20; ++k) j.tick();  // no waypoints: it holds the joints where they are
  EXPECT_EQ(c.state(), Controller::State::Running);
  EXPECT_NEAR(c.get_vector("Cmd1")(0), 0.1, 1e-12);
  EXPECT_NEAR(c.get_vector("Cmd2")(0), 0.2, 1e-12);
  Eigen::VectorXd plan(6);
  plan << 0.5, 0.3, 0.3, 1.0, -0.2, 0.0;
  c.set("Waypoints", plan);
  const auto at = run(j);
  ASSERT_EQ(at.size(), 2u);
  EXPECT_LE((at[0] - Eigen::Vector2d(0.3, 0.3)).cwiseAbs().maxCoeff(), 0.01);
  EXPECT_LE((at[1] - Eigen::Vector2d(-0.2, 0.0)).cwiseAbs().maxCoeff(), 0.01);
  ASSERT_TRUE(c.ended() && c.ended()->done);
}

TEST(JointTrajectory, WaypointsThatAreNoTrajectoryAtTheInputEndItAborted) {
  ControllerUnderTest c("JointTrajectory", {"a b"});
  Joints j{c, Eigen::Vector2d(0.1, 0.2), Eigen::Vector2d::Zero()};
  c.start();
  j.tick();
  Eigen::VectorXd plan(5);
  plan << 0.5, 0.3, 0.3, 1.0, -0.2;
  c.set("Waypoints", plan);
  j.tick();
  ASSERT_TRUE(c.ended().has_value());
  EXPECT_FALSE(c.ended()->done);
  EXPECT_EQ(c.ended()->reason, "input Waypoints: 5 numbers are no whole waypoints of 3 (a time, then a position for "
                               "each of the 2 joints)");
}

TEST(JointTrajectory, EachRunFollowsTheParametersPlanAgain) {
  ControllerUnderTest c("JointTrajectory", args({"a b", "0.01", "position", "2", "60", "0.01"}));
  Joints j{c, Eigen::Vector2d(0.1, 0.2), Eigen::Vector2d::Zero()};
  c.start();
  expect_reached(run(j));
  j.q = Eigen::Vector2d(-0.3, 0.4);  // moved meanwhile: the next run starts from there
  c.start();
  EXPECT_EQ(c.get("Reached"), 3.0) << "not written before the run's first tick";
  expect_reached(run(j));
  ASSERT_TRUE(c.ended() && c.ended()->done);
}

TEST(JointTrajectory, AJointWithNoPositionEndsItAbortedAfterTheTimeoutNamingIt) {
  ControllerUnderTest c("JointTrajectory", args({"a b", "0.01", "position", "2", "0.5", "0.01"}));
  c.start();
  for (int k = 0; k < 60 && c.state() == Controller::State::Running; ++k) {
    c.set("Q1", Joints::one(0.1));  // joint b says nothing
    c.step();
  }
  ASSERT_TRUE(c.ended().has_value());
  EXPECT_EQ(c.ended()->reason, "no position of joint b within 0.5 s: is the world serving it?");
  EXPECT_EQ(c.writes("Cmd1"), 0u) << "nothing commanded before every joint's position is known";
}

std::string refusal(const std::vector<std::string>& params) {
  return dca::joint_control::testing::refusal("JointTrajectory", params);
}

TEST(JointTrajectory, BadParametersAreRefusedNamingThem) {
  EXPECT_EQ(refusal({"", "0.01"}), "JointTrajectory /test: parameter 'joints' ('') names no joint");
  EXPECT_EQ(refusal({"a b c d e f g h i"}), "JointTrajectory /test: parameter 'joints' ('a b c d e f g h i') names 9 "
                                            "joints: at most 8 (give the others to another leaf)");
  EXPECT_EQ(refusal({"a b a"}), "JointTrajectory /test: parameter 'joints' ('a b a') names joint 'a' twice");
  EXPECT_EQ(refusal(args({"a b", "0.01", "position", "2", "60", "0.01"}, {"1", "2"})),
            "JointTrajectory /test: parameter 'waypoints': 2 numbers are no whole waypoints of 3 (a time, then a "
            "position for each of the 2 joints)");
  EXPECT_EQ(refusal(args({"a", "0.01", "position", "2", "60", "0.01"}, {"1", "0", "1", "0.5"})),
            "JointTrajectory /test: parameter 'waypoints': waypoint 2's time 1 is not after the one before (1)");
  EXPECT_EQ(refusal(args({"a", "0.01", "position", "2", "60", "0.01"}, {"-1", "0"})),
            "JointTrajectory /test: parameter 'waypoints': waypoint 1's time -1 is negative");
  EXPECT_NE(refusal({"a", "0"}).find("parameter 'tolerance' must be positive"), std::string::npos);
  EXPECT_NE(refusal({"a", "0.01", "effort"}).find("parameter 'interface' must be position or velocity"),
            std::string::npos);
  EXPECT_EQ(refusal({"shoulder_pan_joint, elbow_joint"}), "(accepted)");
}

}  // namespace
