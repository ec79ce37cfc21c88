#pragma once
// A scripted, open-loop door opening for the simulated world: no controllers, commands computed from the
// world's ground truth (where the handle and the hinge are). It demonstrates that the door can be opened and
// is what `dca sim` runs when no --script is given. C++17-clean.
#include <string>

#include "worlds/door/world.h"

namespace dca::sim {

/// The steps of the scripted opening, in order.
enum class DoorPhase { drive, pregrasp, approach, close, press, push, done, failed };

/// "drive", "pregrasp", ... for messages and recordings.
const char* to_string(DoorPhase p);

/// Drives the robot to the stop pose (laser ~0.7 m from the door), puts the open gripper in front of the
/// handle, approaches until the wrist sensor feels the hit, closes the gripper, presses the handle and
/// pushes the door open along its arc with the base, until the door reaches `target_angle`.
class ScriptedDoorOpening {
 public:
  /// `target_angle` in radians (default 75 degrees).
  explicit ScriptedDoorOpening(double target_angle = 1.3089969389957472);

  /// The commands for the coming step, from the world's current state. Call once per step.
  Commands update(const World& world);
  DoorPhase phase() const { return phase_; }
  /// Simulated time at which each phase started (index: DoorPhase), -1 if not reached.
  double phase_start(DoorPhase p) const { return start_[static_cast<int>(p)]; }
  /// Why the script failed (phase() == failed).
  const std::string& failure() const { return failure_; }

 private:
  void enter(DoorPhase p, double t);
  void fail(const std::string& why, double t);
  DoorPhase phase_ = DoorPhase::drive;
  double target_;
  double start_[8] = {0, -1, -1, -1, -1, -1, -1, -1};
  double free_force_[3] = {0, 0, 0};  // the wrist force before the approach (the tool's weight)
  int settled_ = 0;
  std::string failure_;
};

}  // namespace dca::sim
