#include "controllers/math/kinematics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace dca::math {
namespace {

// A planar 2R arm (links 1.0 and 0.5 along x, joints about z) on a 0.3 m column, then a fixed tool 0.1 m on.
const char* kTwoLink = R"(<?xml version="1.0"?>
<robot name="two_link">
  <link name="base"/> <link name="l1"/> <link name="l2"/> <link name="tool"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
    <origin xyz="0 0 0.3" rpy="0 0 0"/><axis xyz="0 0 1"/><limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
  <joint name="j2" type="continuous"><parent link="l1"/><child link="l2"/>
    <origin xyz="1.0 0 0" rpy="0 0 0"/><axis xyz="0 0 1"/></joint>
  <joint name="tcp" type="fixed"><parent link="l2"/><child link="tool"/>
    <origin xyz="0.6 0 0" rpy="0 0 0"/></joint>
</robot>)";

Chain TwoLink() {
  std::string err;
  auto c = Chain::FromUrdfString(kTwoLink, "two_link.urdf", "base", "tool", &err);
  EXPECT_TRUE(c.has_value()) << err;
  return *c;
}

/// Column i of J is the twist between poses tp (joint i at +h) and tm (at -h): linear part, then angular.
void ExpectColumnIsTheFiniteDifference(const JacobianMatrix& J, int i, const Eigen::Isometry3d& tp,
                                       const Eigen::Isometry3d& tm, double h) {
  const Eigen::Vector3d v = (tp.translation() - tm.translation()) / (2 * h);
  const Eigen::AngleAxisd d(tp.linear() * tm.linear().transpose());
  const Eigen::Vector3d w = d.axis() * d.angle() / (2 * h);
  EXPECT_NEAR((J.block<3, 1>(0, i) - v).norm(), 0.0, 1e-6) << "column " << i;
  EXPECT_NEAR((J.block<3, 1>(3, i) - w).norm(), 0.0, 1e-6) << "column " << i;
}

TEST(KinematicsTest, ReadsTheMovableJointsInOrder) {
  const Chain c = TwoLink();
  EXPECT_EQ(c.dof(), 2);
  EXPECT_EQ(c.joint_names(), (std::vector<std::string>{"j1", "j2"}));
  EXPECT_DOUBLE_EQ(c.lower(0), -2);
  EXPECT_DOUBLE_EQ(c.upper(0), 2);
  EXPECT_LT(c.lower(1), -1e8);  // continuous: no limits
}

TEST(KinematicsTest, ForwardMatchesThePlanarFormula) {
  const Chain c = TwoLink();
  for (double a : {0.0, 0.3, -1.2}) {
    for (double b : {0.0, 0.7, 2.5}) {
      JointVector q(2);
      q << a, b;
      const Eigen::Vector3d p = c.Forward(q).translation();
      EXPECT_NEAR(p.x(), std::cos(a) + 0.6 * std::cos(a + b), 1e-12);
      EXPECT_NEAR(p.y(), std::sin(a) + 0.6 * std::sin(a + b), 1e-12);
      EXPECT_NEAR(p.z(), 0.3, 1e-12);
    }
  }
}

// The Jacobian against central finite differences of Forward, for a 6R arm with skewed axes and offsets.
TEST(KinematicsTest, JacobianMatchesFiniteDifferences) {
  std::vector<Joint> js;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int i = 0; i < 6; ++i) {
    Joint j;
    j.name = std::to_string(i);  // (not "j" + ...: GCC 12 -Wrestrict false positive at -O3)
    j.type = i == 3 ? Joint::Type::kPrismatic : Joint::Type::kRevolute;
    j.origin.translation() = Eigen::Vector3d(u(rng), u(rng), u(rng)) * 0.4;
    j.origin.linear() = Eigen::AngleAxisd(u(rng), Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized()).toRotationMatrix();
    j.axis = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized();
    js.push_back(j);
  }
  Chain c(js);
  Eigen::Isometry3d tool = Eigen::Isometry3d::Identity();
  tool.translation() = Eigen::Vector3d(0.05, 0.0, 0.12);
  c.set_tool(tool);
  JointVector q(6);
  for (int i = 0; i < 6; ++i) q[i] = u(rng);
  JacobianMatrix J;
  c.Jacobian(q, &J);
  const double h = 1e-6;
  for (int i = 0; i < 6; ++i) {
    JointVector qp = q, qm = q;
    qp[i] += h;
    qm[i] -= h;
    ExpectColumnIsTheFiniteDifference(J, i, c.Forward(qp), c.Forward(qm), h);
  }
}

TEST(KinematicsTest, MobileJacobianMatchesFiniteDifferences) {
  const Chain arm = TwoLink();
  BasePose base{0.4, -0.2, 0.7};
  JointVector q(2);
  q << 0.5, -0.9;
  JacobianMatrix J;
  MobileJacobian(base, arm, q, &J);
  ASSERT_EQ(J.cols(), 5);
  const double h = 1e-6;
  auto pose = [&](int i, double d) {
    BasePose b = base;
    JointVector qq = q;
    if (i == 0) b.x += d;
    else if (i == 1) b.y += d;
    else if (i == 2) b.yaw += d;
    else qq[i - 3] += d;
    return MobileForward(b, arm, qq);
  };
  for (int i = 0; i < 5; ++i) {
    ExpectColumnIsTheFiniteDifference(J, i, pose(i, h), pose(i, -h), h);
  }
}

TEST(KinematicsTest, ErrorsNameTheFileAndTheLink) {
  std::string err;
  EXPECT_FALSE(Chain::FromUrdfString(kTwoLink, "two_link.urdf", "base", "hand", &err).has_value());
  EXPECT_EQ(err, "two_link.urdf: no link 'hand'");
  EXPECT_FALSE(Chain::FromUrdfString(kTwoLink, "two_link.urdf", "l2", "l1", &err).has_value());
  EXPECT_EQ(err, "two_link.urdf: link 'l1' is not below link 'l2'");
  EXPECT_FALSE(Chain::FromUrdfString("<robot", "bad.urdf", "a", "b", &err).has_value());
  EXPECT_EQ(err, "bad.urdf: not a valid URDF document");
  EXPECT_FALSE(Chain::FromUrdfFile("/nonexistent/robot.urdf", "a", "b", &err).has_value());
  EXPECT_EQ(err, "/nonexistent/robot.urdf: cannot open the URDF file");
}

}  // namespace
}  // namespace dca::math
