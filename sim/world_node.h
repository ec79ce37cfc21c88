#pragma once
// The world as a process (`dca sim --serve`): the simulated robot and door behind ports, and the clock master
// of every node on simulated time (ARCHITECTURE.md, "Time" and "The robot: device ports").
//
// The world is hosted by the ordinary node runtime (host/node.h) as a component named `world` (by default)
// whose ports are the world's signals (sim/world.h): outputs arm.q, arm.qd, base.pose, base.vel, wrist.wrench,
// laser.range, camera.handle, door.angle, door.handle_angle, gripper.width, gripper.state; inputs
// base.cmd_vel, arm.cmd_qd, gripper.cmd. Every one is a vector (laser.range and the gripper's are vector[1]),
// as the hardware-facing controllers' device ports are. So the supervisor wires it like any node:
// `connect {out = "arm.q", to = LEAF, in = "Q", set}` sent to the world, `connect {out = "Cmd", to = "world",
// in = "base.cmd_vel", set}` sent to the leaf, then `activate`.
//
// Clock master requests (besides the node's own):
//   clock {name}  -> ok {now}   the channel's node subscribes to `advance` (host/node.h); dropped when its
//                                channel closes or it does not answer an advance in time
//   go {}         -> ok {now}   time starts (or resumes) flowing
//   hold {}       -> ok {now}   time stops after the current tick
//   status {}     -> ok {now, t, running, steps, wall_s, subscribers = [names], dropped = [reasons],
//                       door_angle, handle_angle, gripper_state, base_pose = [x, y, yaw], latched, grasping,
//                       rounds, advances, round_p50_us, round_p99_us, round_max_us}: a round is one lock-step
//                       tick with subscribers due (advances sent -> last reply), in wall time
//
// Each tick: the commands that arrived are applied (base and arm commands older than command_timeout count
// as zero, as a drive's watchdog would; the gripper keeps its last command), the world steps one period to t;
// then, if any subscriber is due (its next deadline <= t, or t is a multiple of sync_period, when every
// subscriber is advanced so that one whose timers were just made is woken), the sensors are written to the
// outputs and flushed, `advance {t}` goes to each due subscriber, and the next tick waits for all replies
// (each reply's `next` is remembered), after which the commands they wrote are drained. A subscriber that
// does not answer within tick_timeout is dropped with a message naming it.
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "host/component.h"
#include "host/loop.h"
#include "host/node.h"
#include "host/wire.h"
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
  std::string record;             ///< CSV file to record to ("" = none), see sim/recorder.h
  double record_period = 0.01;    ///< s between recorded rows
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
