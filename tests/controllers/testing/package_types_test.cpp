// dca::testing::ControllerUnderTest with a package's objects linked in (as dca_add_controller_test links them):
// the package's types reach the registry through its entry point, marked with its name, when the first
// ControllerUnderTest is made. The package here is `door` (controllers/door).
#include <dca/testing/controller.h>

#include <gtest/gtest.h>

#include <dca/registry.h>

namespace {

using dca::testing::ControllerUnderTest;

TEST(ControllerUnderTestOfAPackage, ItsTypesAreInTheRegistryUnderItsName) {
  ControllerUnderTest c("DistanceThreshold", {"0.5"});
  const dca::Manifest* m = dca::Registry::global().manifest("DistanceThreshold");
  ASSERT_NE(m, nullptr);
  EXPECT_EQ(m->package, "door");
  c.start();
  c.set("Distance", 0.8);
  c.step();
  EXPECT_FALSE(c.ended().has_value());
  c.set("Distance", 0.4);
  c.step();
  ASSERT_TRUE(c.ended().has_value());
  EXPECT_TRUE(c.ended()->done);
  EXPECT_EQ(c.ended()->number(), 0.4);
}

TEST(ControllerUnderTestOfAPackage, ASecondInstanceAdoptsNothingTwice) {
  ControllerUnderTest a("DistanceThreshold");
  ControllerUnderTest b("AddVelocity");
  b.start();
  Eigen::VectorXd v = Eigen::VectorXd::LinSpaced(9, 1, 9);
  b.set("In1", v);
  b.set("In2", v);
  b.step();
  EXPECT_EQ(b.get_vector("Out"), 2 * v);
}

}  // namespace
