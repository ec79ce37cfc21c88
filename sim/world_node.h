#pragma once
// The world as a process (`dca sim --serve`): the simulated robot and door behind ports, and the clock master
// of every node on simulated time (docs/time.md; docs/data-plane.md, "Device ports: the robot").
//
// The world is hosted by the ordinary node runtime (host/node.h) as a component named `world` (by default)
// whose ports are the world's signals (sim/world.h): outputs arm.q, arm.qd, base.pose, base.vel, wrist.wrench,
// laser.range, camera.handle, door.angle, door.handle_angle, gripper.width, gripper.state; inputs
// base.cmd_vel, arm.cmd_qd, gripper.cmd. Every one is a vector (laser.range and the gripper's are vector[1]),
// as the hardware-facing controllers' device ports are. So the supervisor wires it like any node:
// `connect {out = "arm.q", to = LEAF, in = "Q", set}` sent to the world, `connect {out = "Cmd", to = "world",
// in = "base.cmd_vel", set}` sent to the leaf, then `activate`.
//
// The clock master is host/lockstep.h (requests clock, go, hold, status); the world is what it steps. The
// world's `status {}` adds its state to the clock's: door_angle, handle_angle, gripper_state,
// base_pose = [x, y, yaw], base_vel, arm_q, arm_qd, latched, grasping: the state at its time, whereas the sensor
// outputs (`read`) hold what was last published, at the last tick with a subscriber due.
//
// Taps (host/net/tap.h): `tap {path, port_type, size, units, queue}` adds a tap input "tap:PATH" to the world component
// (answered {input}); the supervisor then links the output at PATH to it. Being the clock's owner, the world
// takes in exactly the samples written before each tick (counted like every link into it), and at each step
// records them (with --record FILE.mcap) at their writers' ticks (the stamps), on one channel per port
// (tap::topic_of, JSON Schema tap::json_schema). `record_end {}` closes the recording now and answers {summary}
// (Recorder::summary: the per-channel counts, the tap samples dropped). The world's own writes are stamped with
// simulated time too (a tap of its signals elsewhere).
//
// Each tick (host/lockstep.h): the commands that arrived are applied (base and arm commands older than
// command_timeout count as zero, as a drive's watchdog would, and so do those of a writer the clock master lost
// or forgot for a new instance, from that tick until it writes again; the gripper keeps its last command) and the world
// steps one period to t; when subscribers are due, the sensors are written to the outputs and flushed before
// they are advanced, and the commands they wrote are drained after their replies.
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <dca/component.h>

#include "host/port.h"
#include "host/loop.h"
#include "host/node.h"
#include "host/codec/wire.h"
#include "sim/world.h"

namespace dca {
class Channel;
}

namespace dca::sim {

/// How the world process runs.
struct WorldNodeOptions {
  double command_timeout = 0.05;  ///< s: a base or arm command not refreshed for this long counts as zero
  double sync_period = 0.01;      ///< s: every subscriber is advanced at least this often
  int tick_timeout_ms = 10000;    ///< how long a subscriber may take to answer an advance
  bool realtime = false;          ///< pace time to the wall clock (else as fast as the nodes allow)
  double duration = -1;           ///< s of simulated time after which time holds (-1: never)
  std::string record;             ///< file to record to, MCAP or CSV ("" = none), see sim/recorder.h
  double record_period = 0.01;    ///< s between recorded rows
  std::string trace;              ///< file the lock-step trace goes to ("" = none; docs/time.md)
};

/// The world component and its clock master, on one Loop.
class WorldNode {
 public:
  WorldNode(Loop& loop, World& world, WorldNodeOptions options);
  ~WorldNode();
  WorldNode(const WorldNode&) = delete;
  WorldNode& operator=(const WorldNode&) = delete;

  /// Makes the component the node hosts (call once, from the node's factory).
  std::unique_ptr<Component> make_component(const std::string& name);
  /// The node's request hook (Node::on_request): clock, go, hold, status.
  bool handle(const std::shared_ptr<Channel>& ch, const wire::Message& m);
  /// The node that hosts this world: `options` (name, daemon, key_file, host) with type "World" when empty and
  /// no clock master of its own; its component is make_component's and its requests go to handle first.
  /// Start it with Node::start; it must not outlive this WorldNode.
  std::unique_ptr<Node> make_node(NodeOptions options);
  /// Starts time flowing (as `go`).
  void go();
  /// Simulated time in nanoseconds.
  std::int64_t now() const;
  /// Called once when `duration` is reached (time then holds).
  std::function<void()> on_duration;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace dca::sim
