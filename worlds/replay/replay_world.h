#pragma once
// The replay world (docs/recording.md, "Replay"): a recording stands in for the simulator. A run recorded with
// `dca run ... --record REC.mcap --record-ports ...` holds the world's signals (/dca/world/signals) and its
// outputs exactly as they were published (/dca/world/outputs, sim/device_node.h); `--world replay:REC.mcap`
// serves them again at their recorded ticks, with the same ports, while the commands it takes are dropped. No
// physics: the controllers under test run live against what the robot did. A URDF world's link frames' names
// (/world/links/frames) and its URDF (/robot_description) are read too, so that the replay's own recording
// holds them as the recorded one does. C++17-clean.
#include <cstdint>
#include <string>
#include <vector>

#include "sim/device_world.h"

namespace dca::sim {

/// What a replay serves: the recorded world's signals and its published outputs.
struct ReplayRecording {
  double period = 1e-3;
  std::vector<DeviceSignal> sensors, commands;
  std::vector<std::int64_t> times;          ///< each publish's time (ns), ascending
  std::vector<std::vector<double>> values;  ///< each publish's values, the sensors' in order, flat
  std::vector<RecordedPort> ports;          ///< the controller outputs recorded with numbers (--record-ports)
  std::vector<frames::Frame> frames;        ///< links.frames' frames (/world/links/frames' first message)
  std::string robot_description;            ///< the URDF (/robot_description), "" when not recorded
};

/// Reads the recording of `path` (at most 1 GiB). Throws std::invalid_argument("FILE: why") when it cannot be read
/// or holds no world outputs (recorded without --record-ports).
ReplayRecording read_replay(const std::string& path);

/// The spec's file: "replay:FILE" gives FILE; "" for any other spec.
std::string replay_file(const std::string& spec);

class ReplayWorld final : public DeviceWorld {
 public:
  ReplayWorld(std::string path, ReplayRecording rec);
  double period() const override { return rec_.period; }
  double time() const override { return static_cast<double>(steps_) * rec_.period; }
  const std::vector<DeviceSignal>& sensors() const override { return rec_.sensors; }
  const std::vector<DeviceSignal>& commands() const override { return rec_.commands; }
  void command(std::size_t, const double*, std::size_t) override {}
  void writer_gone(std::size_t) override {}
  void step() override;  // the publishes due at the new tick become the outputs
  void sensor(std::size_t i, double* out) const override;
  // What the run shows: the publishes replayed and recorded, the file.
  void status(StatusSink& sink) const override;
  std::string describe() const override;
  const std::vector<RecordedPort>& recorded_ports() const override { return rec_.ports; }
  // A URDF world's link frames and description as recorded: its replay records them alike.
  const std::vector<frames::Frame>& frames() const override { return rec_.frames; }
  std::string robot_description() const override { return rec_.robot_description; }
  std::vector<std::string> summary() const override;
  std::vector<std::string> warnings() const override { return {}; }

 private:
  void catch_up();  // the latest publish at or before now (half a period's slack) becomes the outputs
  std::string path_;
  ReplayRecording rec_;
  std::vector<std::size_t> offsets_;  // each sensor's first value in a publish
  std::int64_t steps_ = 0;
  std::size_t next_ = 0;              // the next publish to serve
  std::vector<double> now_;           // the outputs served
};

}  // namespace dca::sim
