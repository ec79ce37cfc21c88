// Pid alone (dca/testing/controller.h): no running system, a simulated clock that moves only when stepped.
#include <dca/testing/controller.h>

#include <gtest/gtest.h>

using dca::testing::ControllerUnderTest;

TEST(Pid, CommandsKpTimesTheError) {
  ControllerUnderTest pid("Pid", {"1.0", "2.0"});  // setpoint 1, kp 2 (ki, kd 0; period 0.01)
  pid.start();
  pid.set("Measured", 0.25);
  pid.step();  // one period: one MainCalc
  EXPECT_DOUBLE_EQ(pid.get("Command"), 1.5);
}

TEST(Pid, IntegratesTheErrorOverTime) {
  ControllerUnderTest pid("Pid", {"1.0", "0", "10"});  // ki 10
  pid.start();
  pid.set("Measured", 0.0);
  pid.advance(0.1);  // ten periods of error 1: the integral is 0.1
  EXPECT_EQ(pid.ticks(), 10u);
  EXPECT_NEAR(pid.get("Command"), 1.0, 1e-12);
}

TEST(Pid, CommandIsZeroAfterHalt) {
  ControllerUnderTest pid("Pid", {"1.0", "2.0"});
  pid.start();
  pid.step();
  ASSERT_NE(pid.get("Command"), 0.0);
  pid.halt();
  EXPECT_EQ(pid.get("Command"), 0.0);  // Command is an actuator: halt() writes it zero
}

TEST(Pid, ANegativeGainIsRefused) {
  EXPECT_THROW(ControllerUnderTest("Pid", {"1.0", "-2.0"}), std::invalid_argument);
}
