#include "worlds/door/door_world.h"

#include <array>
#include <cmath>
#include <cstdio>
#include <iterator>
#include <string>

namespace dca::sim {
namespace {

constexpr std::size_t kArm = 6;                                      // joints
constexpr std::size_t kOwnSensors = std::size(kSensorSignals);       // the aliases' outputs come after these
constexpr std::size_t kOwnCommands = std::size(kCommandSignals);     // and their inputs after these
constexpr std::size_t kArmCommand = 1;                               // arm.cmd_qd

template <std::size_t N>
std::vector<double> vec(const std::array<double, N>& a) {
  return {a.begin(), a.end()};
}

}  // namespace

void door_signals(std::vector<DeviceSignal>* sensors, std::vector<DeviceSignal>* commands) {
  for (const auto& s : kSensorSignals) sensors->push_back({s.name, s.size, s.units});
  for (const auto& s : kCommandSignals) commands->push_back({s.name, s.size, s.units});
  static_assert(std::size(kArmJoints) == kArm);
  for (const char* j : kArmJoints) {
    const std::string p = std::string("joint.") + j;
    sensors->push_back({p + ".position", 1, "rad", true});
    sensors->push_back({p + ".velocity", 1, "rad/s", true});
    sensors->push_back({p + ".effort", 1, "N m", true});
    commands->push_back({p + ".velocity_command", 1, "rad/s", true, kCommandSignals[kArmCommand].name});
  }
}

DoorDeviceWorld::DoorDeviceWorld(const WorldConfig& config, double command_timeout)
    : world_(config),
      period_ns_(std::llround(config.period * 1e9)),
      timeout_ns_(std::llround(command_timeout * 1e9)) {
  door_signals(&sensors_, &commands_);
}

void DoorDeviceWorld::command(std::size_t i, const double* v, std::size_t n) {
  if (i >= commands_.size() || n != commands_[i].size) return;
  if (i >= kOwnCommands) {  // a joint's alias: its element of arm.cmd_qd
    cmd_.arm_qd[i - kOwnCommands] = v[0];
    arm_at_ = tick_;
  } else if (i == 0) {
    for (std::size_t k = 0; k < 3; ++k) cmd_.base_vel[k] = v[k];
    base_at_ = tick_;
  } else if (i == 1) {
    for (std::size_t k = 0; k < 6; ++k) cmd_.arm_qd[k] = v[k];
    arm_at_ = tick_;
  } else {
    cmd_.gripper_close = v[0] > 0.5;
  }
}

// A drive command's writer is lost or restarted (at this tick): the drive stops at once, as a robot's driver
// does on losing its writer, until the new writer's first command. The gripper keeps its position command.
void DoorDeviceWorld::writer_gone(std::size_t i) {
  if (i == 0) cmd_.base_vel = {}, base_at_ = -1;
  if (i == kArmCommand || i >= kOwnCommands) cmd_.arm_qd = {}, arm_at_ = -1;  // the arm's drive, however written
}

void DoorDeviceWorld::step() {
  Commands c = cmd_;
  const auto stale = [&](std::int64_t at) { return at < 0 || (tick_ - at) * period_ns_ > timeout_ns_; };
  if (stale(base_at_)) c.base_vel = {};
  if (stale(arm_at_)) c.arm_qd = {};
  world_.set_commands(c);
  applied_ = c;
  world_.step();
  ++tick_;
}

void DoorDeviceWorld::sensor(std::size_t i, double* out) const {
  const Sensors& s = world_.sensors();
  const double pose[3] = {s.base_pose.x, s.base_pose.y, s.base_pose.yaw};
  const double grip = static_cast<double>(static_cast<int>(s.gripper));
  const double* data[] = {s.arm_q.data(),  s.arm_qd.data(),        pose,          s.base_vel.data(),
                          s.wrench.data(), &s.laser_range,         s.camera_handle.data(), &s.door_angle,
                          &s.handle_angle, &s.gripper_width,       &grip};
  if (i >= sensors_.size()) return;
  if (i >= kOwnSensors) {  // joint j's position, velocity or effort
    const std::size_t j = (i - kOwnSensors) / 3;
    const std::array<double, kArm>* of[] = {&s.arm_q, &s.arm_qd, &s.arm_effort};
    out[0] = (*of[(i - kOwnSensors) % 3])[j];
    return;
  }
  for (std::uint32_t k = 0; k < sensors_[i].size; ++k) out[k] = data[i][k];
}

void DoorDeviceWorld::status(StatusSink& sink) const {
  const Sensors& s = world_.sensors();
  sink.number("door_angle", s.door_angle);
  sink.number("handle_angle", s.handle_angle);
  sink.integer("gripper_state", static_cast<int>(s.gripper));
  sink.numbers("base_pose", {s.base_pose.x, s.base_pose.y, s.base_pose.yaw});
  sink.numbers("base_vel", vec(s.base_vel));
  sink.numbers("base_cmd", vec(applied_.base_vel));
  sink.numbers("arm_cmd", vec(applied_.arm_qd));
  sink.numbers("arm_q", vec(s.arm_q));
  sink.numbers("arm_qd", vec(s.arm_qd));
  sink.flag("latched", world_.latched());
  sink.flag("grasping", world_.grasping());
}

std::string DoorDeviceWorld::describe() const {
  const WorldConfig& c = world_.config();
  char line[160];
  std::snprintf(line, sizeof line, "door %.3f m wide, robot at (%.3f, %.3f, %.1f deg)", c.door.width, c.base_start.x,
                c.base_start.y, c.base_start.yaw * 180 / M_PI);
  return line;
}

std::vector<std::string> DoorDeviceWorld::summary() const {
  char line[64];
  std::snprintf(line, sizeof line, "door at %.1f deg", world_.sensors().door_angle * 180 / M_PI);
  return {line};
}

// Its CSV export only: an MCAP recording is the generic one (sim/device_node.cpp), one channel per signal named
// and shaped as its live topic (/world/arm/q {"value": [...]}), so one Foxglove layout serves a live run and its
// recording.
std::unique_ptr<Recorder> DoorDeviceWorld::own_recorder(const std::string& path) {
  if (is_mcap(path)) return nullptr;
  auto r = std::make_unique<Recorder>(path, csv_header());
  recording_.emplace(*r);
  return r;
}

void DoorDeviceWorld::record(Recorder& r) {
  if (recording_ && &recording_->recorder() == &r) recording_->record(world_.sensors(), -1);
}

}  // namespace dca::sim
