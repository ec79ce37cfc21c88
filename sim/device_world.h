#pragma once
// dca::sim::DeviceWorld: a simulated robot seen only through its device ports (docs/data-plane.md, "Device ports:
// the robot"), the layer that sim/device_node.h serves to controllers: named vector signals out (sensors), named
// vector signals in (commands), stepped one fixed period at a time. The generic URDF world (sim/urdf/) is one;
// C++17-clean, so both the Simbody side and the C++20 node see it.
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "host/codec/frames.h"
#include "sim/recorder.h"

namespace dca::sim {

/// A signal of a device world: its port name, vector size and units.
struct DeviceSignal {
  std::string name;
  std::uint32_t size = 1;
  std::string units;
  /// A joint interface offered beside the world's own signals as another name of the same state or actuator
  /// (docs/worlds.md, "Joint aliases"): an output is written only while something is connected to it, so that
  /// a run that does not read it is what it was without it.
  bool alias = false;
  /// A command input: the command input whose actuator it drives too ("" when its own). Writers of inputs of
  /// one actuator are one writer at a time (docs/safety.md): a second one's samples are refused.
  std::string actuator = {};
};

/// A controller output as a recording holds it (docs/recording.md, "Replaying ports"): every sample's tick and
/// values, for a world that writes them again in place of the live writer (the replay world).
struct RecordedPort {
  std::string path;                  ///< "main.door.hit.Out": the output's path, as in `dca graph`
  std::uint32_t size = 1;            ///< doubles per sample
  std::vector<std::int64_t> times;   ///< each sample's tick (ns), ascending
  std::vector<double> values;        ///< the samples, flat
};

/// Where a world writes its `status {}` fields (the node turns them into the reply's map).
class StatusSink {
 public:
  virtual ~StatusSink() = default;
  virtual void number(const std::string& key, double v) = 0;
  virtual void numbers(const std::string& key, const std::vector<double>& v) = 0;
  /// A map {name = value}.
  virtual void table(const std::string& key, const std::vector<std::pair<std::string, double>>& entries) = 0;
  virtual void texts(const std::string& key, const std::vector<std::string>& lines) = 0;
  virtual void flag(const std::string& key, bool v) = 0;
  virtual void integer(const std::string& key, std::int64_t v) = 0;
};

/// A world behind device ports. Not thread-safe; deterministic: the same commands give the same sensors.
class DeviceWorld {
 public:
  virtual ~DeviceWorld() = default;
  /// The step (s).
  virtual double period() const = 0;
  /// Simulated time (s).
  virtual double time() const = 0;
  /// The outputs (sensors) and the inputs (commands), in port order.
  virtual const std::vector<DeviceSignal>& sensors() const = 0;
  virtual const std::vector<DeviceSignal>& commands() const = 0;
  /// A sample of command `i` (n values) arrived before the next step.
  virtual void command(std::size_t i, const double* v, std::size_t n) = 0;
  /// The writer of command `i` is gone (lost, or replaced by a new instance): its safe value applies until a new
  /// sample comes.
  virtual void writer_gone(std::size_t i) = 0;
  /// The emergency stop (docs/safety.md, "Emergency stop"), latched (true) or released (false). While latched
  /// the world gets no command sample (sim/device_node.h keeps them) and holds every actuator stopped: a
  /// velocity or an effort zero, a position where the joint is. After the release each command keeps that safe
  /// value until its next sample. By default: writer_gone() of every command input at the press (its safe
  /// value), nothing at the release.
  virtual void estop(bool latched) {
    if (!latched) return;
    for (std::size_t i = 0; i < commands().size(); ++i) writer_gone(i);
  }
  /// Advances one period.
  virtual void step() = 0;
  /// Sensor `i`'s current value: sensors()[i].size values into `out`.
  virtual void sensor(std::size_t i, double* out) const = 0;
  /// The world's part of `status {}`.
  virtual void status(StatusSink& sink) const = 0;
  /// One line saying what runs, for the process's "world ready" line.
  virtual std::string describe() const = 0;
  /// Lines for the end of a run (what the safety layer did), and warnings of loading.
  virtual std::vector<std::string> summary() const = 0;
  virtual std::vector<std::string> warnings() const = 0;
  /// The link frames the sensor "links.frames" holds, 7 numbers each (host/codec/frames.h): for viewers and
  /// recordings, as foxglove.FrameTransforms. None by default.
  virtual const std::vector<frames::Frame>& frames() const {
    static const std::vector<frames::Frame> none;
    return none;
  }
  /// Recorded controller outputs the world can write again, each as the output "replay:PATH" of the world
  /// component, sample by sample at its recorded tick (sim/device_node.h). None by default.
  virtual const std::vector<RecordedPort>& recorded_ports() const {
    static const std::vector<RecordedPort> none;
    return none;
  }
  /// The robot's URDF text for viewers (/robot_description), "" when there is none.
  virtual std::string robot_description() const { return {}; }
  /// A world with a recording of its own format (the door world's CSV export): the
  /// Recorder for `path`, its channels added (nullptr: the generic recording, MCAP only, one channel per sensor
  /// signal). Throws std::runtime_error("FILE: reason") when it cannot be written.
  virtual std::unique_ptr<Recorder> own_recorder(const std::string& path) {
    (void)path;
    return nullptr;
  }
  /// With own_recorder: the world's signals now into `r` (at the start and every record period).
  virtual void record(Recorder& r) { (void)r; }
};

}  // namespace dca::sim
