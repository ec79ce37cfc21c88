// dca::testing::ControllerUnderTest (dca/testing/controller.h): one controller alone on simulated time, linked
// against dca::testing only (no node, no socket). The types under test are registered here, as a test of types
// outside a package would; package_types_test.cpp links a package's objects instead.
#include <dca/testing/controller.h>

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

#include <dca/registry.h>

namespace {

const dca::InSpec<double> kIn{.name = "In"};
const dca::InSpec<Eigen::Vector3d> kV{.name = "V"};
const dca::InSpec<dca::PortValue> kMsg{.name = "Msg"};
const dca::OutSpec<double> kOut{.name = "Out", .actuator = true};
const dca::OutSpec<Eigen::Vector3d> kVOut{.name = "VOut", .actuator = true};
const dca::OutSpec<dca::PortValue> kEcho{.name = "Echo"};
const dca::Param<double> kGain{.name = "gain", .def = 1, .min = 0};

// Out = gain In, VOut = 2 V, Echo = Msg; DONE(In) once In > 100, ABORTED when In < 0. Every hook is overridden
// and none calls a base: halt() must still zero the actuators.
class Doubler final : public dca::PeriodicController {
  DCA_CONTROLLER(Doubler)
  void on_configure() override { configured_ += 1; }
  void on_start(const msgpack::object& init) override {
    if (init.type != msgpack::type::NIL) offset_ = init.as<double>();
  }
  void on_halt() override {}
  void MainCalc() override {
    double x = 0;
    if (in_.read(x) == dca::Read::None) return;
    out_.write(gain_ * x + offset_);
    Eigen::Vector3d v;
    if (v_.read(v) != dca::Read::None) vout_.write(2 * v);
    dca::PortValue m;
    if (msg_.read(m) == dca::Read::New) echo_.write(m.get());
    if (x > 100) Done(x);
    if (x < 0) Abort("negative input");
  }

  dca::In<double> in_;
  dca::In<Eigen::Vector3d> v_;
  dca::In<dca::PortValue> msg_;
  dca::Out<double> out_;
  dca::Out<Eigen::Vector3d> vout_;
  dca::Out<dca::PortValue> echo_;
  double gain_;
  double offset_ = 0;
  int configured_ = 0;
};

dca::Manifest Doubler::Describe() {
  return {.type = "FixtureDoubler",
          .inputs = {kIn, kV, kMsg},
          .outputs = {kOut, kVOut, kEcho},
          .params = {kGain, PeriodParam(0.01)}};
}

Doubler::Doubler(const dca::ControllerContext& ctx)
    : PeriodicController(ctx), in_(port(kIn)), v_(port(kV)), msg_(port(kMsg)), out_(port(kOut)),
      vout_(port(kVOut)), echo_(port(kEcho)), gain_(param(kGain)) {}

DCA_REGISTER_CONTROLLER(Doubler);

// Message ports (dca/msgs.h): Cmd.linear.x = the first joint's position, Cmd.angular.z = the number of joints.
const dca::InSpec<dca::msgs::JointState> kJoints{.name = "Joints"};
const dca::OutSpec<dca::msgs::Twist> kCmd{.name = "Cmd", .actuator = true};

class JointsToTwist final : public dca::PeriodicController {
  DCA_CONTROLLER(JointsToTwist)
  void MainCalc() override {
    if (joints_.read(js_) == dca::Read::None || js_.position.empty()) return;
    dca::msgs::Twist t;
    t.linear.x = js_.position[0];
    t.angular.z = static_cast<double>(js_.name.size());
    cmd_.write(t);
  }
  dca::In<dca::msgs::JointState> joints_;
  dca::Out<dca::msgs::Twist> cmd_;
  dca::msgs::JointState js_;  // a member: read() fills it in place
};

dca::Manifest JointsToTwist::Describe() {
  return {.type = "FixtureJointsToTwist", .inputs = {kJoints}, .outputs = {kCmd}, .params = {PeriodParam(0.01)}};
}

JointsToTwist::JointsToTwist(const dca::ControllerContext& ctx)
    : PeriodicController(ctx), joints_(port(kJoints)), cmd_(port(kCmd)) {}

DCA_REGISTER_CONTROLLER(JointsToTwist);

using dca::testing::ControllerUnderTest;

TEST(ControllerUnderTest, MessagesGoInAndComeOutAndHaltWritesTheDefaultMessage) {
  ControllerUnderTest c("FixtureJointsToTwist");
  c.start();
  dca::msgs::JointState js;
  for (const char* n : {"a", "b"}) {
    dca::msgs::Name name;
    ASSERT_TRUE(name.assign(n));
    ASSERT_TRUE(js.name.push_back(name));
    ASSERT_TRUE(js.position.push_back(static_cast<double>(js.position.size()) + 0.5));
  }
  c.set_message("Joints", js);
  c.step();
  const auto t = c.get_message<dca::msgs::Twist>("Cmd");
  EXPECT_EQ(t.linear.x, 0.5);
  EXPECT_EQ(t.angular.z, 2.0);
  EXPECT_THROW(c.set_message("Joints", t), std::invalid_argument);  // a Twist at a JointState input
  EXPECT_THROW((void)c.get_message<dca::msgs::Wrench>("Cmd"), std::invalid_argument);
  c.halt();
  EXPECT_EQ(c.get_message<dca::msgs::Twist>("Cmd"), dca::msgs::Twist{});  // an actuator: zeros
  EXPECT_EQ(c.writes("Cmd"), 2u);
}

TEST(ControllerUnderTest, StepRunsOneMainCalcPerPeriodOnSimulatedTime) {
  ControllerUnderTest c("FixtureDoubler", {"3"});
  c.start();
  EXPECT_EQ(c.state(), dca::Controller::State::Running);
  c.set("In", 2.0);
  EXPECT_EQ(c.get("Out"), 0.0);  // nothing runs until time moves
  EXPECT_TRUE(c.step());
  EXPECT_EQ(c.get("Out"), 6.0);
  EXPECT_EQ(c.ticks(), 1u);
  EXPECT_DOUBLE_EQ(c.now(), 0.01);
  c.advance(0.1);  // ten more periods
  EXPECT_EQ(c.ticks(), 11u);
  EXPECT_EQ(c.writes("Out"), 11u);
  EXPECT_NEAR(c.now(), 0.11, 1e-12);
}

TEST(ControllerUnderTest, VectorsAndValuesGoInAndComeOut) {
  ControllerUnderTest c("FixtureDoubler");
  c.start();
  EXPECT_EQ(c.get_vector("VOut"), Eigen::Vector3d::Zero());  // zeros of its size before the first sample
  c.set("In", 1.0);
  c.set("V", Eigen::Vector3d(1, 2, 3));
  c.set_value("Msg", std::string("hello"));
  c.step();
  EXPECT_EQ(c.get_vector("VOut"), Eigen::Vector3d(2, 4, 6));
  EXPECT_EQ(c.get_value("Echo").get().as<std::string>(), "hello");
}

TEST(ControllerUnderTest, HaltZeroesEveryActuatorWhateverTheHooksDo) {
  ControllerUnderTest c("FixtureDoubler", {"2"});
  c.start();
  c.set("In", 5.0);
  c.set("V", Eigen::Vector3d(1, 1, 1));
  c.step();
  ASSERT_EQ(c.get("Out"), 10.0);
  c.halt();
  EXPECT_EQ(c.state(), dca::Controller::State::Stopped);
  EXPECT_EQ(c.get("Out"), 0.0);
  EXPECT_EQ(c.get_vector("VOut"), Eigen::Vector3d::Zero());
  const auto ticks = c.ticks();
  c.advance(1.0);  // the timer stopped with halt()
  EXPECT_EQ(c.ticks(), ticks);
}

TEST(ControllerUnderTest, AnInitialValueReachesOnStart) {
  ControllerUnderTest c("FixtureDoubler");
  c.start(0.5);
  c.set("In", 1.0);
  c.step();
  EXPECT_EQ(c.get("Out"), 1.5);
}

TEST(ControllerUnderTest, DoneAndAbortAreSeenWithTheirValueAndReason) {
  ControllerUnderTest c("FixtureDoubler");
  c.start();
  c.set("In", 200.0);
  c.step();
  ASSERT_TRUE(c.ended().has_value());
  EXPECT_TRUE(c.ended()->done);
  EXPECT_EQ(c.ended()->number(), 200.0);
  EXPECT_EQ(c.state(), dca::Controller::State::Finished);
  EXPECT_EQ(c.get("Out"), 0.0);  // ending halts, so the actuators are zero too

  c.start();  // again: ended() is cleared
  EXPECT_FALSE(c.ended().has_value());
  c.set("In", -1.0);
  c.step();
  ASSERT_TRUE(c.ended().has_value());
  EXPECT_FALSE(c.ended()->done);
  EXPECT_EQ(c.ended()->reason, "negative input");
  EXPECT_THROW((void)c.ended()->number(), std::runtime_error);
}

TEST(ControllerUnderTest, ABadParameterFailsAsANodeStartWould) {
  try {
    ControllerUnderTest c("FixtureDoubler", {"-1"});
    FAIL() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("parameter 'gain'"), std::string::npos) << e.what();
  }
  EXPECT_THROW(ControllerUnderTest("NoSuchType"), std::invalid_argument);
}

TEST(ControllerUnderTest, PortMistakesNameThePortAndTheTypes) {
  ControllerUnderTest c("FixtureDoubler");
  try {
    c.set("Inn", 1.0);
    FAIL() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("no input 'Inn'"), std::string::npos) << e.what();
  }
  try {
    c.set("V", 1.0);
    FAIL() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("'V' is vector[3], not scalar"), std::string::npos) << e.what();
  }
  EXPECT_THROW(c.set("V", Eigen::Vector2d(1, 2)), std::invalid_argument);
  EXPECT_THROW((void)c.get("VOut"), std::invalid_argument);
  EXPECT_THROW((void)c.get("Nope"), std::invalid_argument);
}

TEST(ControllerUnderTest, StepWithNothingPendingSaysSo) {
  ControllerUnderTest c("FixtureDoubler");
  EXPECT_FALSE(c.step());  // not started: no timer
  EXPECT_EQ(c.now(), 0.0);
}

}  // namespace
