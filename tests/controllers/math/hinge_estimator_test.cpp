#include "controllers/math/hinge_estimator.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace dca::math {
namespace {

constexpr double kPi = 3.14159265358979323846;

TEST(HingeEstimatorTest, ConvergesOnASyntheticArcWithNoise) {
  const Eigen::Vector2d hinge(2.0, 0.5);
  const double radius = 0.85;
  HingeEstimator est(Eigen::Vector2d(1.7, 0.8), 0.7, 0.0);
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 0.001);
  // The hand sweeps 30 degrees of the arc, 300 samples.
  for (int i = 0; i <= 300; ++i) {
    const double a = -kPi / 2 + (kPi / 6) * i / 300.0;
    est.Add(hinge + radius * Eigen::Vector2d(std::cos(a), std::sin(a)) + Eigen::Vector2d(noise(rng), noise(rng)));
  }
  EXPECT_LT((est.centre() - hinge).norm(), 0.02);
  EXPECT_NEAR(est.radius(), radius, 0.02);
  EXPECT_NEAR(est.arc(), kPi / 6, 0.02);
}

TEST(HingeEstimatorTest, KeepsThePriorUntilEnoughArcIsSwept) {
  HingeEstimator est(Eigen::Vector2d(0, 0), 1.0, 0.2);
  EXPECT_EQ(est.centre(), Eigen::Vector2d(0, 0));
  EXPECT_EQ(est.radius(), 1.0);
  const Eigen::Vector2d hinge(0.1, -0.05);
  for (int i = 0; i <= 200; ++i) {
    const double a = 0.6 * i / 200.0;
    est.Add(hinge + 0.9 * Eigen::Vector2d(std::cos(a), std::sin(a)));
    if (i == 20) {  // 0.06 rad swept: still the prior
      EXPECT_FALSE(est.fitted());
      EXPECT_EQ(est.centre(), Eigen::Vector2d(0, 0));
    }
  }
  EXPECT_TRUE(est.fitted());
  EXPECT_LT((est.centre() - hinge).norm(), 0.01);
  EXPECT_NEAR(est.radius(), 0.9, 0.01);
}

TEST(HingeEstimatorTest, TangentIsPerpendicularToTheRadius) {
  HingeEstimator est(Eigen::Vector2d(1, 1), 0.8, 1.0);
  const Eigen::Vector2d p(1.8, 1.0);
  const Eigen::Vector2d t = est.Tangent(p, true);
  EXPECT_NEAR(t.norm(), 1.0, 1e-12);
  EXPECT_NEAR(t.dot(p - est.centre()), 0.0, 1e-12);
  EXPECT_GT(t.y(), 0.9);  // counter-clockwise at angle 0 points along +y
  EXPECT_LT(est.Tangent(p, false).y(), -0.9);
}

TEST(HingeEstimatorTest, ResetForgetsTheSamples) {
  HingeEstimator est(Eigen::Vector2d(0, 0), 1.0, 1.0);
  est.Add({3, 3});
  est.Add({3.1, 3.2});
  est.Reset();
  EXPECT_EQ(est.samples(), 0);
  EXPECT_EQ(est.centre(), Eigen::Vector2d(0, 0));
}

}  // namespace
}  // namespace dca::math
