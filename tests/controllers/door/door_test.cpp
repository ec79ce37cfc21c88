// The door-opening controller library on simulated time (controllers/door/): each controller's maths and its
// life cycle, with its inputs fed by a test source and its outputs read back.
#include <gtest/gtest.h>

#include <cmath>

#include "controllers/door/redundancy_resolution.h"
#include "controllers/door/visual_servoing.h"
#include "controllers/robot/model.h"
#include "tests/support/controller_fixture.h"
#include "tests/support/door_package.h"

namespace {

using dca::robot::Vec3;
using dca::robot::Vec6;
using dca::robot::Vec9;
constexpr double kPi = 3.14159265358979323846;

class DoorTest : public dca::testing::ControllerFixture {
 protected:
  DoorTest() { dca::testing::add_door_types(); }
};

Vec6 ReadyPose() { return (Vec6() << 0.1513, 0.711, -3.428, 0.1658, 1.151, 1.503).finished(); }

// The command's tool twist is realised exactly on top of the motion its base velocity gives the robot.
TEST_F(DoorTest, RedundancyResolutionRealisesTheTwistOnTopOfTheBaseVelocity) {
  const auto arm = dca::robot::arm();
  dca::math::JointVector w(9);
  w << 10, 10, 10, 1, 1, 1, 1, 1, 1;
  dca::math::RedundancyParams params;
  params.damping = 1e-6;
  params.limit_gain = 0;
  Vec9 cmd;
  cmd << 0.05, -0.02, 0.03, 0, 0.1, 0, 0.2, 0.1, 0.05;
  Vec3 base;
  Vec6 qd;
  dca::door::RedundancyResolution::Solve(arm, cmd, ReadyPose(), w, params, &base, &qd);
  dca::math::JointVector q = ReadyPose(), all(9);
  all << base, qd;
  dca::math::JacobianMatrix J;
  dca::math::MobileJacobian(dca::math::BasePose{}, arm, q, &J);
  dca::math::JointVector base_only = dca::math::JointVector::Zero(9);
  base_only.head<3>() = cmd.tail<3>();
  const Vec6 expected = J * base_only + cmd.head<6>();
  EXPECT_LT((J * all - expected).norm(), 1e-6);
  // A pure base command moves the robot rigidly: the arm stays still.
  cmd.head<6>().setZero();
  dca::door::RedundancyResolution::Solve(arm, cmd, ReadyPose(), w, params, &base, &qd);
  EXPECT_LT(qd.norm(), 1e-9);
  EXPECT_LT((base - cmd.tail<3>()).norm(), 1e-9);
}

TEST_F(DoorTest, VisualServoingTurnsTowardsTheHandle) {
  const double f = 320 / std::tan(kPi / 6);
  const Vec9 right = dca::door::VisualServoing::Law(400, 0.25, 0.8, f, 320);
  EXPECT_DOUBLE_EQ(right[6], 0.25);
  EXPECT_LT(right[8], 0);  // handle right of centre: turn right (negative yaw rate)
  EXPECT_NEAR(dca::door::VisualServoing::Law(320, 0.25, 0.8, f, 320)[8], 0, 1e-15);
  EXPECT_GT(dca::door::VisualServoing::Law(100, 0.25, 0.8, f, 320)[8], 0);
  EXPECT_TRUE(right.head<6>().isZero());  // the arm does not move relative to the base
}

// The handle's image point and its height give its position in the base frame (the world's pinhole camera).
TEST_F(DoorTest, VisualServoingLocatesTheHandleFromItsImagePoint) {
  const Eigen::Isometry3d camera = dca::robot::camera();
  const double f = 320 / std::tan(kPi / 6);
  for (const Eigen::Vector3d& p : {Eigen::Vector3d(1.9, 0.0, 1.0), Eigen::Vector3d(1.2, -0.3, 1.0),
                                  Eigen::Vector3d(0.9, 0.2, 1.0)}) {
    const Eigen::Vector3d c = camera.inverse() * p;
    const double u = 320 - f * c.y() / c.x(), v = 240 - f * c.z() / c.x();
    const auto at = dca::door::VisualServoing::Locate(u, v, camera, f, 320, 240, 1.0);
    ASSERT_TRUE(at.has_value());
    EXPECT_NEAR(at->x(), p.x(), 1e-9);
    EXPECT_NEAR(at->y(), p.y(), 1e-9);
  }
  // A pixel above the horizon never reaches the handle's height.
  EXPECT_FALSE(dca::door::VisualServoing::Locate(320, 0, camera, f, 320, 240, 1.0).has_value());
  // Steering lines the gripper (at y = -0.075) up with the handle: no turn when it is on that line.
  EXPECT_NEAR(dca::door::VisualServoing::Steer({1.0, -0.075}, -0.075, 0.25, 1.5)[8], 0, 1e-15);
  EXPECT_GT(dca::door::VisualServoing::Steer({1.0, 0.1}, -0.075, 0.25, 1.5)[8], 0);  // handle left: turn left
  EXPECT_DOUBLE_EQ(dca::door::VisualServoing::Steer({1.0, 0.1}, -0.075, 0.25, 1.5)[6], 0.25);
}

// The admittance acts on the horizontal force only: the tool's weight does not move it.
TEST_F(DoorTest, CompliantCtrlGivesWayToTheHorizontalForceOnly) {
  auto& c = start("CompliantCtrl", {}, "/c", {{"W", 6, "Wrench"}, {"J", 6, "Joints"}});
  auto& w = source("W");
  auto& j = source("J");
  const auto arm = dca::robot::arm();
  dca::math::JointVector q = ReadyPose();
  const Eigen::Matrix3d R = arm.Forward(q).linear();
  Vec6 wrench = Vec6::Zero();
  wrench.head<3>() = R.transpose() * Eigen::Vector3d(0, 0, -9.3);
  w.write(wrench);
  j.write(ReadyPose());
  timers.advance_to(1 * kTick);
  EXPECT_TRUE(latest(c, "Vel").isZero(1e-12));
  wrench.head<3>() = R.transpose() * Eigen::Vector3d(5, 0, -30);
  w.write(wrench);
  j.write(ReadyPose());
  timers.advance_to(2 * kTick);
  const Eigen::VectorXd v = latest(c, "Vel");
  EXPECT_NEAR(v[0], 0.001 * (5 - 1), 1e-9);  // along the force, beyond the 1 N deadband
  EXPECT_NEAR(v[1], 0, 1e-9);
  EXPECT_NEAR(v[2], 0, 1e-12);
}

TEST_F(DoorTest, VisualServoingAbortsWhenTheHandleIsLost) {
  auto& vs = make("VisualServoing", {}, "/vs");
  auto& f = feed("F", 3, "/vs", "Feature");
  ep.activate("s");
  ASSERT_EQ(configured(vs), "");
  ASSERT_EQ(started(vs), "");
  f.write((Vec3() << 330, 240, 1).finished());
  timers.advance_to(1 * kTick);
  EXPECT_GT(latest(vs, "Vel")[6], 0);
  f.write((Vec3() << 0, 0, 0).finished());  // not visible
  timers.advance_to(400 * kMs);
  EXPECT_TRUE(events.empty());
  timers.advance_to(600 * kMs);
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].second.kind, dca::ComponentEvent::Kind::Aborted);
  EXPECT_EQ(events[0].second.reason, "lost sight of the handle for more than 0.5 s");
  EXPECT_TRUE(latest(vs, "Vel").isZero());
}

TEST_F(DoorTest, DistanceThresholdIsDoneAtTheDistance) {
  auto& d = make("DistanceThreshold", {"0.7"}, "/d");
  auto& s = feed(dca::scalar_port("S"), "/d", "Distance");  // Distance is a scalar
  ep.activate("s");
  ASSERT_EQ(started(d), "");
  for (int i = 0; i < 10; ++i) {
    s.write(1.0 - 0.05 * i);
    timers.advance_to((i + 1) * kTick);
  }
  ASSERT_EQ(events.size(), 1u);
  EXPECT_NEAR(unpack_double(events[0].second.value), 0.7, 1e-12);
}

// A started ForceThreshold(force 6 N, 3 samples) fed one wrench sample a tick by step().
class ForceThresholdTest : public DoorTest {
 protected:
  void SetUp() override {
    start("ForceThreshold", {"6", "3"}, "/t", {{"W", 6, "Wrench"}});
    w_ = &source("W");
  }
  /// Writes `x` and runs one tick.
  void step(const Vec6& x) {
    w_->write(x);
    timers.advance_to(++tick_ * kTick);
  }

 private:
  dca::Output* w_ = nullptr;
  int tick_ = 0;
};

TEST_F(ForceThresholdTest, IgnoresTheToolsWeightAndBriefSpikes) {
  Vec6 weight;
  weight << 0, 0, -9.3, 0, 0, 0;
  for (int i = 0; i < 40; ++i) step(weight);  // past the settle time (0.3 s)
  Vec6 spike = weight;
  spike[0] = 20;
  step(spike);
  step(spike);
  step(weight);  // two samples above: not a hit
  EXPECT_TRUE(events.empty());
  step(spike);
  step(spike);
  step(spike);
  ASSERT_EQ(events.size(), 1u);
  EXPECT_NEAR(unpack_double(events[0].second.value), 20, 1e-9);
}

// The step before a hit detector often ends with a jolt (the base stopping): a reference taken from the jolt's
// first sample would fire at once. During the settle time the reference is learnt, and nothing fires.
TEST_F(ForceThresholdTest, LearnsItsReferenceThroughAJoltAtTheStart) {
  Vec6 weight;
  weight << 0, -9.3, 0, 0, 0, 0;
  Vec6 jolt = weight;
  jolt[2] = 10;
  step(jolt);
  step(jolt);
  for (int i = 0; i < 60; ++i) step(weight);
  EXPECT_TRUE(events.empty()) << "fired on the jolt at the start";
  Vec6 hit = weight;
  hit[0] = -8;
  for (int i = 0; i < 3; ++i) step(hit);
  ASSERT_EQ(events.size(), 1u);
  EXPECT_NEAR(unpack_double(events[0].second.value), 8, 0.1);
}

TEST_F(DoorTest, LinearTrajectoryAbortsWhenNothingIsHit) {
  auto& a = start("LinearTrajectory", {"0.05", "0.01"}, "/a");
  timers.advance_to(100 * kMs);
  EXPECT_DOUBLE_EQ(latest(a, "Vel")[0], 0.05);
  timers.advance_to(300 * kMs);
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].second.reason, "moved 0.01 m without reaching anything");
}

// PressHandle: the handle is a lever (radius 0.075 m); the spring pushes back harder as it turns; at its stop
// the force rises to the limit. Travel 0.048 m > 0.04: DONE. A jammed handle: ABORTED with the reason.
class PressHandleTest : public DoorTest {
 protected:
  // Simulates the arm (integrating the tool's vertical velocity into joint 3's angle, roughly) is overkill:
  // instead the joint angles are those of a tool that moved down by `drop` metres, found by Newton steps.
  Vec6 PoseWithToolDrop(double drop) {
    const auto arm = dca::robot::arm();
    dca::math::JointVector q = ReadyPose();
    const Eigen::Vector3d target = arm.Forward(q).translation() - Eigen::Vector3d(0, 0, drop);
    for (int i = 0; i < 20; ++i) {
      dca::math::JacobianMatrix J;
      arm.Jacobian(q, &J);
      const Eigen::Vector3d e = target - arm.Forward(q).translation();
      const Eigen::MatrixXd Jv = J.topRows<3>();
      q += Jv.completeOrthogonalDecomposition().solve(e);
    }
    return q;
  }
  std::string Run(double stop_at) {
    auto& p = start("PressHandle", {}, "/p", {{"W", 6, "Wrench"}, {"J", 6, "Joints"}});
    auto& w = source("W");
    auto& j = source("J");
    const auto arm = dca::robot::arm();
    double drop = 0, v = 0;
    for (int tick = 1; tick < 5000 && events.empty(); ++tick) {
      drop = std::min(stop_at, drop - v * 1e-3);
      const double angle = std::asin(std::min(1.0, drop / 0.075));
      // The tool feels the lever push up: spring torque / lever, plus a stiff stop at stop_at.
      double up = (0.4 + 1.0 * angle) / 0.075;
      if (drop >= stop_at - 1e-9) up += 5 * tick * 1e-3 * 100;
      dca::math::JointVector q = PoseWithToolDrop(drop);
      const Eigen::Matrix3d R = arm.Forward(q).linear();
      Vec6 wrench = Vec6::Zero();
      wrench.head<3>() = R.transpose() * Eigen::Vector3d(0, 0, up - 0.4 / 0.075) + R.transpose() * Eigen::Vector3d(0, 0, -9.3);
      w.write(wrench);
      j.write(q);
      timers.advance_to(tick * kMs);
      if (events.empty()) v = latest(p, "Vel")[2];
    }
    if (events.empty()) return "running";
    const auto& e = events[0].second;
    return e.kind == dca::ComponentEvent::Kind::Done ? "done " + std::to_string(unpack_double(e.value)) : e.reason;
  }
};

TEST_F(PressHandleTest, IsDoneWhenTheHandleStopsAfterEnoughTravel) {
  const std::string r = Run(0.048);
  ASSERT_EQ(r.substr(0, 5), "done ") << r;
  EXPECT_NEAR(std::stod(r.substr(5)), 0.048, 0.003);
}

TEST_F(PressHandleTest, AbortsWhenTheHandleIsJammed) {
  const std::string r = Run(0.004);
  EXPECT_EQ(r.substr(0, 38), "handle jammed: 30 N reached after 0.00") << r;
}

TEST_F(DoorTest, ConfigCtrlMovesTheBaseUnderTheStillTool) {
  auto& c = start("ConfigCtrl", {}, "/c", {{"J", 6, "Joints"}});
  auto& j = source("J");
  j.write(ReadyPose());
  timers.advance_to(1 * kTick);
  const Eigen::VectorXd v = latest(c, "Vel");
  ASSERT_EQ(v.size(), 9);
  EXPECT_NEAR(v[0], -v[6], 1e-12);  // the tool's twist cancels the base's motion
  EXPECT_NEAR(v[1], -v[7], 1e-12);
  EXPECT_LE(std::hypot(v[6], v[7]), 0.2 + 1e-12);
}

TEST_F(DoorTest, AddVelocitySumsFreshInputsOnly) {
  auto& a = start("AddVelocity", {}, "/a", {{"A", 9, "In1"}, {"B", 9, "In2"}});
  auto& i1 = source("A");
  auto& i2 = source("B");
  i1.write(Vec9::Constant(1.0));
  i2.write(Vec9::Constant(2.0));
  timers.advance_to(1 * kTick);
  EXPECT_TRUE(latest(a, "Out").isApprox(Eigen::VectorXd::Constant(9, 3.0)));
  i1.write(Vec9::Constant(1.0));
  timers.advance_to(2 * kTick);  // In2 went quiet: it counts zero
  EXPECT_TRUE(latest(a, "Out").isApprox(Eigen::VectorXd::Constant(9, 1.0)));
}

// ModelBasedCtrl on a synthetic door: the hand is carried by the door around a hinge 0.85 m to the right;
// the controller must find the hinge, keep pushing along the circle and finish at the target angle.
TEST_F(DoorTest, ModelBasedCtrlFollowsTheCircleAndStopsAtTheTargetAngle) {
  auto& m = start("ModelBasedCtrl", {"0.15", "75", "0.9", "right"}, "/m",
                  {{"P", 3, "BasePose"}, {"J", 6, "Joints"}});
  auto& pose = source("P");
  auto& joints = source("J");
  const auto arm = dca::robot::arm();
  dca::math::JointVector q = ReadyPose();
  const Eigen::Vector3d tool = arm.Forward(q).translation();
  // The base moves instead of the arm (a rigid robot): the hand is at base + tool.
  const Eigen::Vector2d hinge(tool.x(), tool.y() - 0.85);
  double angle = 0;  // door opening angle
  Vec3 base = Vec3::Zero();
  int tick = 0;
  double max_radial_error = 0;
  for (; tick < 20000 && events.empty(); ++tick) {
    const Eigen::Vector2d hand = hinge + 0.85 * Eigen::Vector2d(std::sin(angle), std::cos(angle));
    base.head<2>() = hand - tool.head<2>();
    pose.write(base);
    joints.write(q);
    timers.advance_to((tick + 1) * kMs);
    const Eigen::VectorXd v = latest(m, "Vel");
    const Eigen::Vector2d vel(v[0], v[1]);
    // The door takes the component of the commanded velocity along its circle.
    const Eigen::Vector2d tangent(std::cos(angle), -std::sin(angle));
    angle += vel.dot(tangent) / 0.85 * 1e-3;
    const Eigen::Vector2d radial = (hand - hinge).normalized();
    if (tick > 2000) max_radial_error = std::max(max_radial_error, std::abs(vel.dot(radial)) / 0.15);
  }
  ASSERT_EQ(events.size(), 1u) << "after " << tick << " ticks, angle " << angle * 180 / kPi;
  EXPECT_NEAR(unpack_double(events[0].second.value), 75, 1.0);
  EXPECT_NEAR(angle * 180 / kPi, 75, 2.0);
  EXPECT_LT(max_radial_error, 0.05);  // once fitted, it pushes along the circle
}

}  // namespace
