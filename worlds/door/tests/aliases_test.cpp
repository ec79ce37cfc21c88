// The door world's arm as the generic joint interfaces (worlds/door/door_world.h, docs/worlds.md "Joint
// aliases"): the aliases carry the URDF's joint names, show the same state as arm.q and arm.qd, and a command
// through an alias is that joint's element of arm.cmd_qd, the same drive with the same watchdog.
#include "worlds/door/door_world.h"

#include <gtest/gtest.h>

#include <urdf_model/model.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "sim/urdf_parse.h"

namespace {

using dca::sim::DeviceSignal;
using dca::sim::DoorDeviceWorld;

std::size_t index_of(const std::vector<DeviceSignal>& signals, const std::string& name) {
  for (std::size_t i = 0; i < signals.size(); ++i)
    if (signals[i].name == name) return i;
  ADD_FAILURE() << "no signal " << name;
  return 0;
}

double read(const DoorDeviceWorld& w, const std::string& name) {
  double v[6] = {};
  w.sensor(index_of(w.sensors(), name), v);
  return v[0];
}

std::vector<double> read6(const DoorDeviceWorld& w, const std::string& name) {
  std::vector<double> v(6);
  w.sensor(index_of(w.sensors(), name), v.data());
  return v;
}

// The alias names are the door robot's revolute arm joints, in the order of its URDF.
TEST(DoorAliases, NamesAreTheArmJointsOfTheDoorRobotsUrdf) {
  const auto urdf = dca::sim::parse_urdf_file(std::string(DCA_SOURCE_DIR) +
                                              "/worlds/door/models/mobile_manipulator.urdf");
  std::vector<std::pair<int, std::string>> revolute;  // (line, name) of each revolute joint
  for (const auto& [key, at] : urdf.lines) {
    if (key.rfind("joint:", 0) != 0) continue;
    const std::string name = key.substr(6);
    const auto j = urdf.model->getJoint(name);
    if (j && j->type == urdf::Joint::REVOLUTE) revolute.emplace_back(std::stoi(at), name);
  }
  std::sort(revolute.begin(), revolute.end());
  std::vector<std::string> arm;
  for (const auto& [line, name] : revolute) arm.push_back(name);
  ASSERT_EQ(arm.size(), std::size(dca::sim::kArmJoints));
  for (std::size_t k = 0; k < arm.size(); ++k) EXPECT_EQ(arm[k], dca::sim::kArmJoints[k]);
}

// Each joint's position, velocity and effort outputs and its velocity_command input, the input naming the arm's
// vector input as its actuator; the world's own signals first, unchanged.
TEST(DoorAliases, EveryArmJointHasTheGenericInterfaces) {
  DoorDeviceWorld w(dca::sim::door_world(0), 0.05);
  EXPECT_EQ(w.sensors()[0].name, "arm.q");
  EXPECT_EQ(w.commands()[1].name, "arm.cmd_qd");
  EXPECT_FALSE(w.sensors()[0].alias);
  for (const char* j : dca::sim::kArmJoints) {
    const std::string p = std::string("joint.") + j;
    for (const char* s : {".position", ".velocity", ".effort"}) EXPECT_TRUE(w.sensors()[index_of(w.sensors(), p + s)].alias);
    const auto& in = w.commands()[index_of(w.commands(), p + ".velocity_command")];
    EXPECT_TRUE(in.alias);
    EXPECT_EQ(in.actuator, "arm.cmd_qd");
    EXPECT_EQ(in.size, 1u);
  }
}

// A command through joint 2's alias moves the arm exactly as the same rate in arm.cmd_qd does; the aliases read
// what arm.q and arm.qd read, and the drives' torques hold the arm against gravity.
TEST(DoorAliases, AnAliasCommandIsTheVectorsElementAndTheStateIsTheSame) {
  DoorDeviceWorld by_vector(dca::sim::door_world(0), 0.05), by_alias(dca::sim::door_world(0), 0.05);
  const double rate[6] = {0, 0.2, 0, 0, 0, 0}, one = 0.2;
  const std::size_t alias = index_of(by_alias.commands(), "joint.arm_joint_2.velocity_command");
  for (int k = 0; k < 100; ++k) {
    by_vector.command(1, rate, 6);
    by_alias.command(alias, &one, 1);
    by_vector.step();
    by_alias.step();
  }
  const auto q = read6(by_vector, "arm.q"), qd = read6(by_vector, "arm.qd");
  EXPECT_EQ(q, read6(by_alias, "arm.q"));  // bit for bit: one drive, one command
  EXPECT_EQ(qd, read6(by_alias, "arm.qd"));
  for (std::size_t k = 0; k < 6; ++k) {
    const std::string p = std::string("joint.") + dca::sim::kArmJoints[k];
    EXPECT_EQ(read(by_alias, p + ".position"), q[k]);
    EXPECT_EQ(read(by_alias, p + ".velocity"), qd[k]);
  }
  EXPECT_NEAR(qd[1], 0.2, 0.02);
  EXPECT_GT(std::abs(read(by_alias, "joint.arm_joint_2.effort")), 1.0);  // the shoulder carries the arm
}

// The arm commands the last step applied (the world's status arm_cmd).
std::vector<double> applied_arm(const DoorDeviceWorld& w) {
  struct Sink final : dca::sim::StatusSink {
    std::vector<double> arm;
    void number(const std::string&, double) override {}
    void numbers(const std::string& key, const std::vector<double>& v) override {
      if (key == "arm_cmd") arm = v;
    }
    void table(const std::string&, const std::vector<std::pair<std::string, double>>&) override {}
    void texts(const std::string&, const std::vector<std::string>&) override {}
    void flag(const std::string&, bool) override {}
    void integer(const std::string&, std::int64_t) override {}
  } sink;
  w.status(sink);
  return sink.arm;
}

// The alias's writer lost: the whole arm drive stops, as for the vector's (one actuator).
TEST(DoorAliases, AnAliasWriterGoneStopsTheArm) {
  DoorDeviceWorld w(dca::sim::door_world(0), 100.0);  // no watchdog in this test: writer_gone alone stops it
  const std::size_t alias = index_of(w.commands(), "joint.arm_joint_1.velocity_command");
  const double rate[6] = {0, 0.3, 0, 0, 0, 0};
  for (int k = 0; k < 50; ++k) w.command(1, rate, 6), w.step();
  EXPECT_GT(read(w, "joint.arm_joint_2.velocity"), 0.2);
  for (int k = 0; k < 50; ++k) w.step();
  EXPECT_GT(read(w, "joint.arm_joint_2.velocity"), 0.2) << "the last command holds without its watchdog";
  EXPECT_EQ(applied_arm(w), (std::vector<double>{0, 0.3, 0, 0, 0, 0}));
  w.writer_gone(alias);
  w.step();
  EXPECT_EQ(applied_arm(w), std::vector<double>(6, 0.0));  // from the next step on
  for (int k = 0; k < 300; ++k) w.step();
  EXPECT_NEAR(read(w, "joint.arm_joint_2.velocity"), 0.0, 0.01);
}

}  // namespace
