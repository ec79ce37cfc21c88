#pragma once
// Recording a run of the world as CSV, and drawing such a recording with gnuplot. C++17-clean.
#include <cstdio>
#include <string>

#include "sim/world.h"

namespace dca::sim {

/// The CSV's header line (without newline). Columns, in this order: time (s); q1..q6 (rad); base_x, base_y (m),
/// base_yaw (rad); fx, fy, fz (N), tx, ty, tz (N m) in the sensor frame; door_angle, handle_angle (rad);
/// gripper_width (m), gripper_state (see GripperState); laser (m); phase (a number the writer chooses, e.g.
/// the scripted DoorPhase, -1 if none).
const char* csv_header();

/// Writes one row per call of record() to a CSV file. The constructor throws std::runtime_error("FILE: reason")
/// if the file cannot be written.
class Recorder {
 public:
  explicit Recorder(const std::string& path);
  ~Recorder();
  Recorder(const Recorder&) = delete;
  Recorder& operator=(const Recorder&) = delete;
  /// Appends the world's current sensors (and `phase`).
  void record(const Sensors& s, int phase = -1);
  /// Flushes and closes. False with *error ("FILE: reason") on a write error. The destructor closes too, and
  /// ignores the error.
  bool close(std::string* error);
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  std::FILE* f_ = nullptr;
};

/// Draws a recording: door and handle angles, wrist force, base position against time, and the base's path,
/// to a PNG (gnuplot's pngcairo terminal). False with *error (naming the file) when it cannot.
bool plot_csv(const std::string& csv, const std::string& png, std::string* error);

}  // namespace dca::sim
