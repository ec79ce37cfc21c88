#pragma once
// A world (sim/device_world.h: the door world, a URDF world, any world plug-in's; docs/worlds.md) as a process:
// the world's signals as the ports of a component named `world` (by default), hosted by the ordinary node runtime
// (host/node.h), and the clock master of every node on simulated time (host/lockstep.h) (docs/time.md;
// docs/data-plane.md, "Device ports: the robot"; docs/robots.md).
//
// Each tick: the command samples counted for the world are taken in (the latest of each input goes to
// DeviceWorld::command), the world steps one period, and when subscribers are due its sensors are written to
// the outputs. A command input whose writer the clock master lost or forgot for a new instance is told to the
// world (DeviceWorld::writer_gone). One writer at a time on each command input (docs/safety.md): a second
// writer's samples within the holder's lease (one of its periods, at most writer_lease) are refused, counted
// (status `writers_refused` = {input = n}, `second_writers` = ["INPUT: WRITER refused, held by HOLDER at T s",
// ...]), traced (`T W world.INPUT refused=WRITER holder=HOLDER`), said on stderr once per writer, holder and
// input, and told as often to the supervisors on the clock: the event `second_writer {input = "world.INPUT",
// writer, holder, now}` (each writer "PATH.PORT") on their channels.
// `status {}` is the clock's status and the world's fields. Taps, `record_end`
// and `note`: sim/world_taps.h. With `record`, a world with a recording of its own format writes it
// (DeviceWorld::own_recorder: the door world's signal groups, MCAP or CSV); any other records FILE.mcap: every
// sensor signal every record_period on a channel named as its live topic ("/world/joint/J/position", {"value": [x]}; the
// link frames, DeviceWorld::frames, as foxglove.FrameTransforms), the URDF once on /robot_description,
// beside the tapped ports and the run's lines (docs/recording.md). `robot_description {}` answers {urdf, frames =
// [[parent, child], ...], port = "links.frames"}: what a viewer draws the robot from.
//
// The emergency stop (docs/safety.md, "Emergency stop"): pressed by `estop {source}`, or by a sample above 0.5
// on the world component's input `estop` (kEstopInput; source "input"); released only by `release {what =
// "estop", source}`, refused while that input still reads pressed. While latched no command sample reaches the
// world (they still arrive, are counted for the clock and in status `estop.held_samples`), and the world holds
// every actuator stopped (DeviceWorld::estop) from the tick it was pressed at. Each press and release is traced
// (`T E world.estop pressed by=SOURCE`), said on stderr, kept for the summary (status `estop`, `estop_log`)
// and told to the channels that sent `estop_watch {}` (event `estop {latched, t, source}`).
#include <functional>
#include <memory>
#include <string>

#include <dca/component.h>
#include "host/loop.h"
#include "host/node.h"
#include "host/codec/wire.h"
#include "sim/device_world.h"

namespace dca {
class Channel;
}

namespace dca::sim {

/// The world component's input that presses the emergency stop (a sample above 0.5), beside the commands.
inline constexpr const char* kEstopInput = "estop";

/// How the world process runs.
struct DeviceNodeOptions {
  double sync_period = 0.01;      ///< s: every subscriber is advanced at least this often
  int tick_timeout_ms = 10000;    ///< how long a subscriber may take to answer an advance
  int spin_us = -1;               ///< LockstepOptions::spin_us
  bool realtime = false;          ///< pace time to the wall clock
  double duration = -1;           ///< s of simulated time after which time holds (-1: never)
  std::string trace;              ///< file the lock-step trace goes to ("" = none; docs/time.md)
  double writer_lease = 0.05;     ///< s: the longest a command input stays one writer's after its last sample
                                  ///< (docs/safety.md: one of the writer's periods, at most this)
  std::string record;             ///< the MCAP file to record to ("" = none): the constructor throws for another
  double record_period = 0.01;    ///< s between recorded signals
  /// With an MCAP `record`: the world's outputs as published too, exactly (what a replay serves; see
  /// "Replay" in docs/recording.md): the signals once on /dca/world/signals, every publish on /dca/world/outputs.
  bool record_outputs = false;
  /// With an MCAP `record`: a black box instead of the whole recording (sim/recorder.h; docs/recording.md, "Black
  /// box"), triggered by a fault among the run's lines (`note` with state aborted or lost), on demand
  /// (`blackbox {why}`), by the first refusal of a second writer, and by a storm of limit clamps (box.storm_*).
  bool blackbox = false;
  BlackboxOptions box;
  RecordOptions recording;        ///< an MCAP `record`'s compression and split (a black box: compression only)
};

class DeviceNode {
 public:
  DeviceNode(Loop& loop, DeviceWorld& world, DeviceNodeOptions options);
  ~DeviceNode();
  DeviceNode(const DeviceNode&) = delete;
  DeviceNode& operator=(const DeviceNode&) = delete;

  /// The node that hosts this world (as WorldNode::make_node): start it with Node::start; it must not outlive
  /// this DeviceNode.
  std::unique_ptr<Node> make_node(NodeOptions options);
  /// Starts time flowing (as `go`).
  void go();
  /// Simulated time in nanoseconds.
  std::int64_t now() const;
  /// The reply to `status {}`.
  wire::Value status() const;
  /// Called once when `duration` is reached (time then holds).
  std::function<void()> on_duration;
  /// Why time could not go on (a counted command that never came: the world then stops, its exit code 1), or "".
  const std::string& stuck() const;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace dca::sim
