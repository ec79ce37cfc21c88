#include "controllers/math/redundancy.h"

#include <gtest/gtest.h>

#include <random>

namespace dca::math {
namespace {

class RedundancyTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> u(-1, 1);
    J.resize(6, 9);
    for (int r = 0; r < 6; ++r)
      for (int c = 0; c < 9; ++c) J(r, c) = u(rng);
    twist << 0.1, -0.05, 0.02, 0.0, 0.1, -0.2;
    w = JointVector::Ones(9);
    q = JointVector::Zero(9);
    lo = JointVector::Constant(9, -1e9);
    hi = JointVector::Constant(9, 1e9);
    params.damping = 1e-6;
  }
  JacobianMatrix J;
  Eigen::Matrix<double, 6, 1> twist;
  JointVector w, q, lo, hi, qdot;
  RedundancyParams params;
};

TEST_F(RedundancyTest, ReproducesTheCommandedTwist) {
  Resolve(J, twist, w, q, lo, hi, params, &qdot);
  EXPECT_LT((J * qdot - twist).norm(), 1e-8);
}

TEST_F(RedundancyTest, IsTheMinimumNormSolutionWithUnitWeights) {
  Resolve(J, twist, w, q, lo, hi, params, &qdot);
  const Eigen::MatrixXd Jd = J;
  const Eigen::VectorXd pinv = Jd.completeOrthogonalDecomposition().solve(Eigen::VectorXd(twist));
  EXPECT_LT((Eigen::VectorXd(qdot) - pinv).norm(), 1e-7);
}

TEST_F(RedundancyTest, HeavyWeightsMakeAJointMoveLess) {
  Resolve(J, twist, w, q, lo, hi, params, &qdot);
  const double free_base = qdot.head<3>().norm();
  w.head<3>().setConstant(100.0);
  Resolve(J, twist, w, q, lo, hi, params, &qdot);
  EXPECT_LT(qdot.head<3>().norm(), 0.2 * free_base);
  EXPECT_LT((J * qdot - twist).norm(), 1e-8);  // still the same twist
}

TEST_F(RedundancyTest, DampingBoundsVelocitiesAtASingularity) {
  J.row(5) = J.row(4);  // rank 5: the commanded twist is not reachable exactly
  twist[5] = -twist[4];
  params.damping = 0.05;
  Resolve(J, twist, w, q, lo, hi, params, &qdot);
  EXPECT_TRUE(qdot.allFinite());
  EXPECT_LT(qdot.norm(), 10.0);
}

TEST_F(RedundancyTest, JointNearItsLimitIsPushedBackWithoutDisturbingTheTwist) {
  lo.setConstant(-1.0);
  hi.setConstant(1.0);
  Resolve(J, twist, w, q, lo, hi, params, &qdot);
  const double joint4_free = qdot[4];
  q[4] = 0.95;  // inside the upper margin (0.8 .. 1.0)
  params.limit_gain = 5.0;
  Resolve(J, twist, w, q, lo, hi, params, &qdot);
  EXPECT_LT(qdot[4], joint4_free);                  // moves away from the upper limit
  EXPECT_LT((J * qdot - twist).norm(), 1e-6);       // the task is untouched
}

}  // namespace
}  // namespace dca::math
