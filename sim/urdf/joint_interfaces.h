#pragma once
// The joint interfaces of a URDF robot as device ports, and the safety layer at those ports (docs/robots.md):
// every command is clamped to the joint's limits (URDF <limit>, <safety_controller> soft limits, the interface's
// min/max) and each clamped sample is counted; a command not refreshed for its watchdog_ticks goes stale and
// then holds or zeroes as declared. Pure: no Simbody, no clock; the worlds (Simbody, mock) call it around their
// physics each step. C++17-clean.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "sim/device_world.h"
#include "sim/urdf/description.h"

namespace dca::sim {

/// A joint's state as the world publishes it.
struct JointState {
  double position = 0, velocity = 0, effort = 0;
};

/// What drives a joint during one step: the interface in force and its value after the safety layer.
struct JointDrive {
  JointInterface kind = JointInterface::effort;
  double value = 0;
  bool commanded = false;  ///< the joint has a command interface at all (false: passive)
  std::size_t input = 0;   ///< the command input in force (when commanded)
};

/// The ports of `d`: per moving joint, outputs joint.NAME.position, .velocity, .effort; per declared command
/// interface, the input joint.NAME.KIND_command; when there are inputs, the outputs safety.clamps and
/// safety.stale (counts per input, in input order); then links.frames, 7 numbers per link frame
/// (sim/urdf/frames.h); last the sensors' ports sensor.NAME.GROUP (sim/urdf/sensors.h). Every one a vector.
std::vector<DeviceSignal> joint_sensor_signals(const RobotDescription& d);
std::vector<DeviceSignal> joint_command_signals(const RobotDescription& d);

/// The per-input counts of the safety layer.
struct InputCounts {
  std::uint64_t samples = 0;       ///< samples taken
  std::uint64_t clamped = 0;       ///< samples clamped (counted once each) or dropped (not finite)
  std::uint64_t stale = 0;         ///< times the watchdog tripped (or the writer was lost)
  long first_stale_tick = -1;      ///< the step at which it first went stale (-1: never)
};

class JointInterfaces {
 public:
  explicit JointInterfaces(const RobotDescription& d);

  std::size_t joints() const { return joints_.size(); }
  std::size_t inputs() const { return inputs_.size(); }
  /// The joint and the spec of input `i`.
  std::size_t joint_of(std::size_t i) const { return inputs_[i].joint; }
  const CommandSpec& spec_of(std::size_t i) const { return *inputs_[i].spec; }
  /// "joint.NAME.KIND_command"
  const std::string& input_name(std::size_t i) const { return inputs_[i].name; }

  /// A sample of input `i`: its joint is driven through that interface from the next step on.
  void command(std::size_t i, double value);
  /// Input `i` lost its writer: stale at once, until the next sample.
  void writer_gone(std::size_t i);
  /// The emergency stop latched (true) or released (docs/safety.md, "Emergency stop"): while latched every
  /// commanded joint is driven to rest whatever its commands (velocity and effort 0, a position held where the
  /// joint was at the press, no limit applied); at the release each input keeps that safe value until its next
  /// sample.
  void estop(bool latched);
  bool estopped() const { return estop_; }
  /// Before step `tick`: applies the watchdogs and the limits against the joints' state; the drives follow.
  void begin_step(const std::vector<JointState>& state, long tick);
  const JointDrive& drive(std::size_t joint) const { return drives_[joint]; }
  /// After the step: the commands are one step older.
  void end_step();

  const InputCounts& counts(std::size_t i) const { return inputs_[i].counts; }
  /// Whether input `i` is stale now.
  bool stale(std::size_t i) const { return inputs_[i].stale; }

 private:
  struct Input {
    std::string name;
    std::size_t joint = 0;
    const CommandSpec* spec = nullptr;
    double raw = 0, zero = 0;
    bool has_sample = false, stale = false, gone = false, counted = false;
    long age = 0;
    InputCounts counts;
  };
  double clamp(const Input& in, double v, const JointState& s) const;
  void velocity_bounds(const JointLimitSpec& l, const CommandSpec& c, double q, double* lo, double* hi) const;
  double initial_value(const Input& in) const;
  void estop_step(const std::vector<JointState>& state);

  std::vector<JointSpec> joints_;
  std::vector<Input> inputs_;
  std::vector<std::size_t> active_;  // per joint: the input in force (inputs() when none)
  std::vector<JointDrive> drives_;
  bool estop_ = false;
  std::vector<double> held_;  // estop: per joint, the position at the press (NaN until its first step)
};

}  // namespace dca::sim
