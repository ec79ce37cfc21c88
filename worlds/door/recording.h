#pragma once
// The door world's recording (sim/recorder.h): its signals in groups, as MCAP (one JSON channel per group) or as
// CSV (any other name); `dca plot` (lua/dca/cli/plot.lua) draws either with gnuplot. C++17-clean.
#include <cstdint>
#include <memory>
#include <string>

#include "sim/recorder.h"
#include "worlds/door/world.h"

namespace dca::sim {

/// The CSV's header line (without newline). Columns, in this order: time (s); q1..q6 (rad); base_x, base_y (m),
/// base_yaw (rad); fx, fy, fz (N), tx, ty, tz (N m) in the sensor frame; door_angle, handle_angle (rad);
/// gripper_width (m), gripper_state (see GripperState); laser (m); phase (a number the writer chooses, e.g.
/// the scripted DoorPhase, -1 if none).
const char* csv_header();

/// The MCAP recording's channels, one per signal group, in channel id order (1, 2, ...): /world/arm (q1..q6),
/// /world/base (x, y, yaw), /world/wrench (fx, fy, fz, tx, ty, tz), /world/door (door_angle, handle_angle),
/// /world/gripper (width, state), /world/laser (range), /world/phase (phase). Each message is a JSON object
/// with these fields (numbers), its log time the simulated time in ns.
constexpr int kMcapChannels = 7;

/// A recording of the door world's signals: a Recorder (MCAP or CSV by the name) with the groups' channels
/// first. The constructor throws std::runtime_error("FILE: reason") if the file cannot be written.
class DoorRecording {
 public:
  explicit DoorRecording(const std::string& path);
  /// Takes over an open Recorder made with csv_header() (nothing written to it yet): adds the groups' channels.
  explicit DoorRecording(Recorder& recorder);
  /// Appends the world's current sensors (and `phase`): a CSV row, or one MCAP message per group.
  void record(const Sensors& s, int phase = -1);
  Recorder& recorder() { return *r_; }

 private:
  explicit DoorRecording(std::unique_ptr<Recorder> own);
  std::unique_ptr<Recorder> own_;
  Recorder* r_;
  std::uint16_t first_ = 0;  // the first group's channel
};

/// Converts an MCAP recording of DoorRecording to its CSV (csv_header()'s columns, one row per log time). False
/// with *error ("FILE: why") when it is not such a recording.
bool mcap_to_csv(const std::string& mcap, const std::string& csv, std::string* error);

}  // namespace dca::sim
