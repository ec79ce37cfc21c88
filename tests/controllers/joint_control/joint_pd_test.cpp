// JointPD alone (dca/testing/controller.h) on mock joints (joint_plant.h), on a simulated clock.
#include <dca/testing/controller.h>

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

#include "joint_plant.h"

namespace {

using dca::Controller;
using dca::joint_control::testing::Drive;
using dca::joint_control::testing::Joints;
using dca::testing::ControllerUnderTest;

TEST(JointPD, TheEffortIsKpTimesThePositionErrorPlusKdTimesTheVelocityError) {
  ControllerUnderTest c("JointPD", {"a b", "100", "10", "effort", "0.01", "1.0", "-1.0"});
  Joints j{c, Eigen::Vector2d(0.5, 0.0), Eigen::Vector2d(0.2, -0.1), Drive::Effort};
  c.start();
  j.feed();
  c.step();
  EXPECT_NEAR(c.get_vector("Cmd1")(0), 100 * (1.0 - 0.5) + 10 * (0 - 0.2), 1e-12);
  EXPECT_NEAR(c.get_vector("Cmd2")(0), 100 * (-1.0 - 0.0) + 10 * (0 + 0.1), 1e-12);
  EXPECT_NEAR(c.get_vector("Error")(1), -1.0, 1e-12);
  // a reference and its velocity from the inputs replace the targets
  c.set("Ref", Eigen::Vector2d(0.6, 0.1));
  c.set("RefVel", Eigen::Vector2d(0.3, 0.0));
  c.step();
  EXPECT_NEAR(c.get_vector("Cmd1")(0), 100 * (0.6 - 0.5) + 10 * (0.3 - 0.2), 1e-12);
  EXPECT_NEAR(c.get_vector("Cmd2")(0), 100 * (0.1 - 0.0) + 10 * (0.0 + 0.1), 1e-12);
  EXPECT_EQ(c.writes("Cmd3"), 0u) << "a slot past the joints is never written";
}

TEST(JointPD, WithoutAReferenceItHoldsTheJointsWhereTheyWere) {
  ControllerUnderTest c("JointPD", {"a", "50", "5"});
  Joints j{c, Eigen::VectorXd::Constant(1, 0.3), Eigen::VectorXd::Zero(1), Drive::Effort};
  c.start();
  j.feed();
  c.step();
  EXPECT_EQ(c.get_vector("Cmd1")(0), 0.0) << "where it was: no error";
  j.q(0) = 0.1;  // pushed away
  j.feed();
  c.step();
  EXPECT_NEAR(c.get_vector("Cmd1")(0), 50 * (0.3 - 0.1), 1e-12);
}

TEST(JointPD, ItBringsEffortDrivenJointsToTheirTargetsAndSettles) {
  ControllerUnderTest c("JointPD", {"a b", "100", "20", "effort", "0.01", "0.8", "-0.5"});
  Joints j{c, Eigen::Vector2d(0.0, 0.0), Eigen::Vector2d::Zero(), Drive::Effort};
  c.start();
  for (int k = 0; k < 300; ++k) j.tick();  // 3 s: a unit inertia, 10 rad/s of bandwidth, critically damped
  EXPECT_NEAR(j.q(0), 0.8, 1e-3);
  EXPECT_NEAR(j.q(1), -0.5, 1e-3);
  EXPECT_NEAR(j.qd(0), 0.0, 1e-2);
  EXPECT_EQ(c.state(), Controller::State::Running) << "a PD never ends by itself";
}

TEST(JointPD, ThroughTheVelocityCommandTheReferenceVelocityIsFedForward) {
  ControllerUnderTest c("JointPD", {"a", "4", "0", "velocity"});
  Joints j{c, Eigen::VectorXd::Constant(1, 0.0), Eigen::VectorXd::Zero(1), Drive::Velocity};
  c.start();
  c.set("Ref", Eigen::VectorXd::Constant(1, 0.5));
  c.set("RefVel", Eigen::VectorXd::Constant(1, 0.25));
  j.tick();
  EXPECT_NEAR(c.get_vector("Cmd1")(0), 0.25 + 4 * 0.5, 1e-12);
  c.set("RefVel", Eigen::VectorXd::Zero(1));
  for (int k = 0; k < 300; ++k) j.tick();
  EXPECT_NEAR(j.q(0), 0.5, 1e-4);
}

TEST(JointPD, HaltWritesEveryCommandZero) {
  ControllerUnderTest c("JointPD", {"a b", "100", "0", "effort", "0.01", "1", "1"});
  Joints j{c, Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero(), Drive::Effort};
  c.start();
  j.tick();
  ASSERT_NE(c.get_vector("Cmd1")(0), 0.0);
  c.halt();
  EXPECT_EQ(c.get_vector("Cmd1")(0), 0.0) << "the commands are actuators";
  EXPECT_EQ(c.get_vector("Cmd2")(0), 0.0);
}

TEST(JointPD, AReferenceOfAnotherSizeEndsItAborted) {
  ControllerUnderTest c("JointPD", {"a b", "100"});
  Joints j{c, Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero(), Drive::Effort};
  c.start();
  c.set("Ref", Eigen::Vector3d(1, 2, 3));
  j.tick();
  ASSERT_TRUE(c.ended().has_value());
  EXPECT_FALSE(c.ended()->done);
  EXPECT_EQ(c.ended()->reason, "input Ref: 3 numbers for 2 joints");
}

std::string refusal(const std::vector<std::string>& params) {
  return dca::joint_control::testing::refusal("JointPD", params);
}

TEST(JointPD, BadParametersAreRefusedNamingThem) {
  EXPECT_EQ(refusal({"a b", "100", "0", "effort", "0.01", "1"}),
            "JointPD /test: parameter 'targets': 1 numbers for 2 joints (one per joint, or none)");
  EXPECT_NE(refusal({"a", "-1"}).find("parameter 'kp' must be at least 0"), std::string::npos);
  EXPECT_NE(refusal({"a", "1", "-1"}).find("parameter 'kd' must be at least 0"), std::string::npos);
  EXPECT_NE(refusal({"a", "1", "0", "position"}).find("parameter 'interface' must be effort or velocity"),
            std::string::npos);
  EXPECT_NE(refusal({" , ", "1"}).find("parameter 'joints' (' , ') names no joint"), std::string::npos);
  EXPECT_EQ(refusal({"a"}).find("parameter 2 'kp' is required") != std::string::npos, true);
}

}  // namespace
