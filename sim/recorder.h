#pragma once
// Recording a run of a world as MCAP (FILE.mcap: JSON channels, log time = simulated time; host/codec/mcap.h),
// or as CSV (any other name) for a world that has a CSV export of its own (the door world's,
// worlds/door/recording.h). C++17-clean.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "host/codec/mcap.h"

namespace dca::sim {

/// A black box (docs/recording.md, "Black box"): what the recording would write, held in memory for the last
/// `before` seconds of simulated time and at most `max_bytes`, and written to a file of its own around a trigger.
struct BlackboxOptions {
  double before = 5, after = 1;       ///< s of simulated time kept before a trigger, and written after it
  std::size_t max_bytes = 64u << 20;  ///< the messages held at most (the oldest dropped first, counted)
  /// A storm of limit clamps, a trigger of the world process (sim/device_node.h): at least `storm_clamps`
  /// command samples clamped (the world's "safety.clamps", summed) within `storm_window` s of simulated time.
  /// Once per storm: it is over when the window holds fewer again.
  std::uint64_t storm_clamps = 10;
  double storm_window = 1;
};

/// How an MCAP recording is written (docs/recording.md, "Compression and split"): `dca run --record-compression`,
/// `--record-split`.
struct RecordOptions {
  /// Each chunk's. zstd by default: the recordings are JSON text of numbers, which zstd shrinks more than lz4
  /// (the door world's signals: 2.6 times against 2.0) at a write cost that is a small part of a run's
  /// (tests/bench/RESULTS.md, "Recording"), and it is what the MCAP tools write by default.
  dca::mcap::Compression compression = dca::mcap::Compression::zstd;
  std::uint64_t split_bytes = 0;  ///< a new file once this many bytes are written (0: never)
  std::uint64_t split_ns = 0;     ///< a new file every this much simulated time (0: never)
  /// The header's profile (`dca run --profile`): "" (none: every channel JSON) or "ros2" (the message ports'
  /// channels CDR with ros2msg schemas, add_cdr_channel; the rest stays JSON).
  std::string profile;
};

/// Parses --record-split's value: SIZE (`100MB`, `1.5GB`, `512KB`, bytes) or DURATION (`60s`, `10min`, `1h`).
/// False when it is neither (or zero).
bool parse_split(const std::string& text, RecordOptions* o);

/// A recording file. The constructor throws std::runtime_error("FILE: reason") if the file cannot be written.
class Recorder {
 public:
  /// MCAP when `path` ends in ".mcap"; else a CSV whose first line is `csv_header` (a world without a CSV export
  /// passes none: then any name but FILE.mcap is refused).
  explicit Recorder(const std::string& path, const std::string& csv_header = "");
  /// A black box keeps this much simulated time (ns) beyond `before`: a trigger's tick may lie that far behind
  /// the latest message when it arrives (a fault's line reaches the world while time runs on).
  static constexpr uint64_t kLateTrigger = 2'000'000'000;
  /// The later triggers a black box's file names beside its own (one /dca/blackbox message each), at most.
  static constexpr std::size_t kMaxAlso = 16;
  ~Recorder();
  Recorder(const Recorder&) = delete;
  Recorder& operator=(const Recorder&) = delete;
  /// MCAP only, before any message is written (a CSV ignores it): compression and split. With a split, PATH
  /// itself is not written: the files are PATH without ".mcap" + "-000.mcap", "-001.mcap", ..., each with every
  /// channel. A black box takes the compression only.
  void configure(const RecordOptions& o);
  /// Whether this is an MCAP recording (else CSV).
  bool mcap() const { return mcap_ != nullptr; }
  /// CSV only: one row (its text, without the newline).
  void csv_row(const std::string& row);
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
  /// MCAP only (0 for a CSV): a channel of ROS 2 messages on `topic`, each its CDR (with the encapsulation header),
  /// the schema named `ros_name` ("sensor_msgs/msg/JointState") of encoding ros2msg holding `definition`
  /// (dca::msgs::ros2msg_definition). Meant for a recording of profile "ros2".
  uint16_t add_cdr_channel(const std::string& topic, const std::string& ros_name, const std::string& definition);
  /// The profile configure() set ("" or "ros2").
  const std::string& profile() const { return options_.profile; }
  /// MCAP only: one message (JSON text, or CDR on a channel of add_cdr_channel) on a channel of add_channel at
  /// simulated time `t_ns` (a CSV ignores it).
  void write(uint16_t channel, int64_t t_ns, const std::string& json);
  /// MCAP only, before any message is written (its channels are kept): the recording becomes a black box. PATH
  /// itself is not written: the n-th trigger writes PATH without ".mcap" + "-n.mcap". False for a CSV.
  bool blackbox(const BlackboxOptions& o);
  /// A black box's trigger at simulated time `t` (s) for `why`: once time passes t + after (or at close), the file
  /// of the messages in [t - before, t + after] is written, with {"trigger", "t", "before", "after"} on
  /// /dca/blackbox. A trigger while one is pending is counted in that one: its file has one more message on
  /// /dca/blackbox at the later trigger's time (at most kMaxAlso). Ignored by a plain recording.
  void trigger(double t, const std::string& why);
  /// A black box's messages held now (bytes), and the files it wrote (their summaries).
  std::size_t held_bytes() const;
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
  struct Box;
  std::unique_ptr<Box> box_;    // set for a black box
  uint16_t channel(const dca::mcap::ChannelSpec& spec);
  void put(uint16_t channel, uint64_t t_ns, std::string json);
  long rows_ = 0;
  uint64_t dropped_ = 0;
  RecordOptions options_;
  std::vector<std::string> files_;  // a split recording's files, the open one last
  uint64_t split_at_ = 0;           // the next split's log time (split_ns)
  void next_file();
  void rotate_if_due(uint64_t t_ns);
};

/// Whether `path` names an MCAP file (ends in ".mcap").
bool is_mcap(const std::string& path);

}  // namespace dca::sim
