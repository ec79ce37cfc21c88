// The replay world's plug-in (sim/world_plugin.h; docs/recording.md, "Replay"): `--world replay:REC.mcap`.
#include <memory>
#include <stdexcept>

#include "sim/world_plugin.h"
#include "worlds/replay/replay_world.h"

namespace dca::sim {
namespace {

std::string file_of(const WorldSetup& setup) {
  const std::string file = replay_file(setup.spec);
  if (file.empty()) throw std::invalid_argument("world '" + setup.spec + "': which recording? replay:REC.mcap");
  return file;
}

WorldPlugin plugin() {
  WorldPlugin p;
  p.name = "replay";
  p.summary = "replay:REC.mcap, a recording (dca run --record-ports) served again in place of a simulator";
  p.accepts = [](const std::string& spec) { return !replay_file(spec).empty(); };
  p.make = [](const WorldSetup& setup) -> std::unique_ptr<DeviceWorld> {
    const std::string file = file_of(setup);
    return std::make_unique<ReplayWorld>(file, read_replay(file));
  };
  p.signals = [](const WorldSetup& setup, std::vector<DeviceSignal>* sensors, std::vector<DeviceSignal>* commands) {
    ReplayRecording rec = read_replay(file_of(setup));
    *sensors = std::move(rec.sensors);
    *commands = std::move(rec.commands);
  };
  return p;
}

const WorldRegistration kReplay{plugin()};

}  // namespace
}  // namespace dca::sim
