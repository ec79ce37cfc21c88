// LowPass alone (dca/testing/controller.h).
#include <dca/testing/controller.h>

#include <gtest/gtest.h>

using dca::testing::ControllerUnderTest;

TEST(LowPass, FollowsAStepWithItsTimeConstant) {
  ControllerUnderTest f("LowPass", {"0.09"});  // tau 0.09, period 0.01: a gain of 0.1 per period
  f.start();
  f.set("In", Eigen::Vector2d(1.0, -2.0));
  f.step();
  EXPECT_TRUE(f.get_vector("Out").isApprox(Eigen::Vector2d(0.1, -0.2)));
  f.step();
  EXPECT_TRUE(f.get_vector("Out").isApprox(Eigen::Vector2d(0.19, -0.38)));
}

TEST(LowPass, EndsDoneOnceSettledWithinTolerance) {
  ControllerUnderTest f("LowPass", {"0.09", "0.01", "0.05"});  // tolerance 0.05
  f.start();
  f.set("In", Eigen::VectorXd::Constant(1, 1.0));
  f.advance(1.0);
  ASSERT_TRUE(f.ended().has_value());
  EXPECT_TRUE(f.ended()->done);
  EXPECT_LE(f.ended()->number(), 0.05);
  EXPECT_LT(f.now(), 1.0 + 1e-9);
}

TEST(LowPass, NothingIsWrittenBeforeTheFirstSample) {
  ControllerUnderTest f("LowPass", {"0.09"});
  f.start();
  f.step(5);
  EXPECT_EQ(f.writes("Out"), 0u);
}
