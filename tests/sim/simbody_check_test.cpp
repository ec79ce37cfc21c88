#include "sim/simbody_check.h"

#include <gtest/gtest.h>

#include <cmath>

namespace {

// Regression guard: Debian's Simbody is built without NDEBUG; a Release file compiled without -UNDEBUG
// crashes in realizeTopology(). This builds and steps a Simbody system in whatever build type this is.
TEST(SimbodyCheckTest, PendulumSwingsAsSmallAngleTheoryPredicts) {
  // Unit mass, unit inertia about the centre, 1 m below the pin: I = 2, omega = sqrt(g / 2).
  const double q0 = 0.05, t = 1.0, dt = 1e-3;
  const double expected = q0 * std::cos(std::sqrt(9.81 / 2.0) * t);
  EXPECT_NEAR(dca::sim::pendulum_angle_after(q0, dt, static_cast<int>(t / dt)), expected, 2e-4);
}

TEST(SimbodyCheckTest, ReportsVersion37) { EXPECT_EQ(dca::sim::simbody_version(), "3.7"); }

}  // namespace
