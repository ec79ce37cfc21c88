#pragma once
// Recording a run of the world as MCAP (FILE.mcap: one JSON channel per signal group, log time = simulated
// time; host/codec/mcap.h) or CSV (any other name), and drawing either with gnuplot. C++17-clean.
#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>

#include "sim/world.h"

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

/// Writes the world's signals at each call of record(): a CSV row, or one MCAP message per channel when the
/// path ends in ".mcap". The constructor throws std::runtime_error("FILE: reason") if the file cannot be
/// written.
class Recorder {
 public:
  /// The channels a recording starts with: the door world's signal groups (kMcapChannels, written by record()),
  /// or none (another world's recording: MCAP only, its channels added with add_channel).
  enum class Groups { door, none };
  /// Throws std::runtime_error("FILE: reason") also for Groups::none and a name not ending in ".mcap".
  explicit Recorder(const std::string& path, Groups groups = Groups::door);
  ~Recorder();
  Recorder(const Recorder&) = delete;
  Recorder& operator=(const Recorder&) = delete;
  /// Appends the door world's current sensors (and `phase`); nothing with Groups::none.
  void record(const Sensors& s, int phase = -1);
  /// MCAP only (a CSV ignores it): one message on the channel /dca/events (added at the first note) at simulated
  /// time `t`: {"line": line, "path": path, "state": state} (path and state empty for a line that is no
  /// transition), e.g. a progress line of `dca run` ("main.door.hit: running").
  void note(double t, const std::string& line, const std::string& path, const std::string& state);
  /// MCAP only: one message on the channel /dca/log (added at the first) at simulated time `t`: {"path": path,
  /// "line": line}, a line the process of `path` wrote to its stderr (docs/processes.md, "Output").
  void log(double t, const std::string& path, const std::string& line);
  /// MCAP only (0 for a CSV): a channel of its own on `topic` (a tapped port's, host/net/tap.h), its messages JSON
  /// objects described by the JSON Schema `schema`.
  /// `schema_name`: the schema's name ("" : the topic without its leading slash), e.g. foxglove.FrameTransforms.
  uint16_t add_channel(const std::string& topic, const std::string& schema, const std::string& schema_name = "");
  /// MCAP only: one message (JSON text) on a channel of add_channel at simulated time `t_ns` (a CSV ignores it).
  void write(uint16_t channel, int64_t t_ns, const std::string& json);
  /// Samples a tap dropped (host/net/tap.h), for the summary.
  void set_dropped(uint64_t n) { dropped_ = n; }
  /// Flushes and closes. False with *error ("FILE: reason") on a write error. The destructor closes too, and
  /// ignores the error.
  bool close(std::string* error);
  const std::string& path() const { return path_; }
  /// What was recorded, for the run's summary: "FILE: N rows" (CSV) or "FILE: N messages on K channels
  /// (/world/arm N, ..., /main/door/hit/Force N), C chunks[, D tap samples dropped]" (MCAP: every channel in id
  /// order).
  std::string summary() const;

 private:
  struct Mcap;
  std::string path_;
  std::FILE* f_ = nullptr;
  std::unique_ptr<Mcap> mcap_;  // set when recording MCAP
  long rows_ = 0;
  uint64_t dropped_ = 0;
  Groups groups_ = Groups::door;
};

/// Draws a recording (CSV, or MCAP when `file` ends in ".mcap"): door and handle angles, wrist force, base
/// position against time, and the base's path, to a PNG (gnuplot's pngcairo terminal). False with *error
/// (naming the file) when it cannot.
bool plot_csv(const std::string& file, const std::string& png, std::string* error);

/// Converts an MCAP recording of Recorder to the CSV Recorder writes (csv_header()'s columns, one row per
/// log time). False with *error ("FILE: why") when it is not such a recording.
bool mcap_to_csv(const std::string& mcap, const std::string& csv, std::string* error);

/// Whether `path` names an MCAP file (ends in ".mcap").
bool is_mcap(const std::string& path);

}  // namespace dca::sim
