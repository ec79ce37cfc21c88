#pragma once
// The door world behind device ports (sim/device_world.h): the World of worlds/door/world.h seen as the generic
// layer's named vector signals, so that the same world process (sim/device_node.h) serves it as it serves a
// URDF world. C++17-clean.
//
// Signals: worlds/door/world.h's kSensorSignals (outputs) and kCommandSignals (inputs), in that order; after each,
// the arm's joints as the generic joint interfaces (sim/urdf/joint_interfaces.h) under their URDF names
// (kArmJoints), aliases of the same state and drive (docs/worlds.md, "Joint aliases"): per joint the outputs
// joint.J.position, .velocity (arm.q, arm.qd) and .effort (the drive's torque), and the input
// joint.J.velocity_command, that joint's element of arm.cmd_qd. The arm is one actuator: a writer of any of its
// inputs holds them all (a second writer, on the vector or an alias, is refused: docs/safety.md).
// Commands: base.cmd_vel and arm.cmd_qd not refreshed for `command_timeout` (and those of a writer that is gone,
// until it writes again) count as zero, as a drive's watchdog would; the gripper keeps its last command. A
// sample of the wrong size is ignored.
// Status: door_angle, handle_angle, gripper_state, base_pose [x, y, yaw], base_vel, base_cmd and arm_cmd (what the
// last step applied), arm_q, arm_qd, latched, grasping.
// Recording: MCAP is the generic recording (one channel per signal, as live: /world/arm/q); a CSV name gives its own
// export (worlds/door/recording.h, csv_header()).
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "sim/device_world.h"
#include "worlds/door/recording.h"
#include "worlds/door/world.h"

namespace dca::sim {

/// The arm's joints in the door robot's URDF (worlds/door/models/mobile_manipulator.urdf), in arm.q's order.
inline constexpr const char* kArmJoints[] = {"arm_joint_1", "arm_joint_2", "arm_joint_3",
                                             "arm_joint_4", "arm_joint_5", "arm_joint_6"};

/// The door world's signals (see the file comment): outputs, then inputs.
void door_signals(std::vector<DeviceSignal>* sensors, std::vector<DeviceSignal>* commands);

class DoorDeviceWorld final : public DeviceWorld {
 public:
  /// Throws as World's constructor does.
  DoorDeviceWorld(const WorldConfig& config, double command_timeout);

  double period() const override { return world_.config().period; }
  double time() const override { return world_.time(); }
  const std::vector<DeviceSignal>& sensors() const override { return sensors_; }
  const std::vector<DeviceSignal>& commands() const override { return commands_; }
  void command(std::size_t i, const double* v, std::size_t n) override;
  void writer_gone(std::size_t i) override;
  void step() override;
  void sensor(std::size_t i, double* out) const override;
  void status(StatusSink& sink) const override;
  std::string describe() const override;
  std::vector<std::string> summary() const override;
  std::vector<std::string> warnings() const override { return {}; }
  std::unique_ptr<Recorder> own_recorder(const std::string& path) override;
  void record(Recorder& r) override;

  World& world() { return world_; }

 private:
  World world_;
  std::int64_t period_ns_, timeout_ns_;
  std::int64_t tick_ = 0;            // steps taken
  Commands cmd_, applied_;           // the latest commands; what the last step applied
  std::int64_t base_at_ = -1, arm_at_ = -1;  // the tick the last base / arm command arrived at (-1: none)
  std::vector<DeviceSignal> sensors_, commands_;
  std::optional<DoorRecording> recording_;
};

}  // namespace dca::sim
