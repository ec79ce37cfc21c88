#pragma once
// DoorHarness: the paper's door-opening system (worlds/door/systems/door_open.dca) run in one process against the
// simulated world (sim::World), in closed loop, with the timing the distributed lock-step system has:
//   - the world steps every 1 ms; at tick t it publishes the sensors of the state at t on its device signals,
//     then the controllers due at t run (one TimerServer on a simulated clock, every controller on the aligned
//     grid of its period);
//   - every connection between controllers costs one tick: a sample written at tick k is delivered just
//     before tick k+1 (each connection goes through a relay pumped between ticks, as a node drains its data
//     sockets before it runs its due timers);
//   - device outputs (commands) written at tick t act on the world in its step from t to t + 1 ms, are held
//     between ticks, and a velocity command not refreshed for `stale` (50 ms) counts as zero. The gripper
//     command is a position command: the world holds the last one;
//   - the task is sequenced as the algebra runs it: MotionControl throughout; each step starts by activating its
//     connection sets and running (Init + Run) its controllers, ends on its deciding controller's DONE (then
//     its other controllers are stopped and its sets deactivated) and fails on any of its controllers'
//     ABORTED. With no `reaction` the supervisor reacts at the tick of the event, before the world steps: the
//     stopped drives' zeros act from that step, the next step's controllers start at that tick (their first
//     MainCalc one period later), as the barrier of the lock-step runs them;
//   so the timing is that of ARCHITECTURE.md "Time" (logical execution time) and the harness opens the door
//   of a seed at the same tick as `dca run --sim door` (tests/bench/door_bench.lua prints both).
// Controllers use only their ports; the harness reads the world's ground truth only to record and report.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <deque>
#include <cstdio>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <boost/asio/io_context.hpp>

#include <dca/controller.h>
#include <dca/registry.h>
#include "host/net/endpoint.h"
#include "host/timers.h"
#include "worlds/door/world.h"
#include "tests/support/door_package.h"

namespace dca::testing {

/// One step of the door task.
struct DoorStep {
  std::string name;
  std::vector<std::string> run;   ///< instances started (left to right)
  std::vector<std::string> sets;  ///< connection sets active while it runs
  std::string decider;            ///< its DONE ends the step
};

/// What a run of the task did.
struct DoorRunResult {
  std::vector<double> step_start;  ///< simulated time (s) each step started, in order
  std::vector<double> step_end;
  std::vector<double> step_end_door_angle;  ///< rad, the world's at each step's end
  int steps_done = 0;              ///< steps that ended DONE
  std::string failure;             ///< "" or "<step>: <instance> ABORTED: <reason>" / "<step>: timed out"
  std::string failed_instance;     ///< the instance that aborted
  std::string abort_reason;        ///< its reason
  double door_angle = 0;           ///< degrees, at the end
  double max_door_angle = 0;       ///< degrees
  double time = 0;                 ///< simulated seconds at the end
  double max_hit_force_before_contact = 0;  ///< not used by the harness itself
};

class DoorHarness {
 public:
  static constexpr Nanos kMs = 1'000'000;
  static constexpr const char* kRoot = "/main/dooropensyst/";

  /// The world from `config`; every controller of door_open.dca with the arguments the .dca file gives.
  /// `motion_period` > 0: MotionControl's three controllers at that period (s), holding each command 10 ms,
  /// as `dca run ... --set motion.period=P` runs them (door_open.config's other values).
  explicit DoorHarness(const sim::WorldConfig& config, double motion_period = 0) : world_(config) {
    testing::add_door_types();
    ep_.add_component("world", world_ports_);
    for (const auto& s : sim::kSensorSignals) world_ports_.add_output(vector_port(s.name, s.size, s.units));
    for (const auto& s : sim::kCommandSignals) world_ports_.add_input(vector_port(s.name, s.size, s.units), 16);

    for (auto i : Instances()) {
      if (motion_period > 0 && std::string(i.name).rfind("motionctrl/", 0) == 0) {
        const std::string p = std::to_string(motion_period);
        i.params = std::string(i.name) == "motionctrl/redundancy"
                       ? std::vector<std::string>{"10.0", "1.0", "0.02", p, "0.01"}
                       : std::vector<std::string>{p, "0.01"};
      }
      add(i.type, i.name, i.params);
    }
    for (const auto& l : Connections()) connect(l.from, l.out, l.to, l.in, l.set);

    steps_ = {
        {"VisualServoing", {"visualserv", "camera", "distdetect/threshold", "distdetect/laser"},
         {"visualserv:lbl1", "distdetect/laser:lbl1"}, "distdetect/threshold"},
        {"Approach", {"opengrip", "approach", "hit/threshold", "hit/force"}, {"approach:lbl1", "hit/force:lbl1"},
         "hit/threshold"},
        {"CloseGripper", {"closegrip"}, {}, "closegrip"},
        {"PressHandle", {"presshandle", "pressft", "pressjoints"}, {"presshandle:lbl1"}, "presshandle"},
        {"DoorOpen",
         {"dooropen/model", "dooropen/force", "dooropen/xr4000", "dooropen/puma", "dooropen/compliant",
          "dooropen/config", "dooropen/add"},
         {"dooropen:lbl1", "dooropen/model:lbl1", "dooropen/force:lbl1", "dooropen/xr4000:lbl1",
          "dooropen/puma:lbl1", "dooropen/compliant:lbl1", "dooropen/config:lbl1"},
         "dooropen/model"},
    };
  }

  ~DoorHarness() {
    for (auto& [name, c] : controllers_) ep_.remove_component(path(name));
    for (std::size_t i = 0; i < relays_.size(); ++i) ep_.remove_component("/relay/" + std::to_string(i));
    ep_.remove_component("world");
  }
  DoorHarness(const DoorHarness&) = delete;
  DoorHarness& operator=(const DoorHarness&) = delete;

  /// The full PATH of an instance ("visualserv" -> "/main/dooropensyst/visualserv").
  static std::string path(const std::string& name) { return kRoot + name; }
  sim::World& world() { return world_; }
  Controller* controller(const std::string& name) {
    auto it = controllers_.find(name);
    return it == controllers_.end() ? nullptr : it->second.get();
  }
  const std::vector<DoorStep>& steps() const { return steps_; }
  /// The time of the last tick the controllers ran at (the world is one period ahead).
  Nanos now() const { return timers_.now(); }
  double seconds() const { return to_seconds(timers_.now()); }
  /// The commands the world acted on in its last step.
  const sim::Commands& applied() const { return applied_; }
  /// How long the supervisor takes to end a step after its deciding event (0: at the same tick).
  Nanos reaction = 0;
  /// Called after every world step (for recording and fault injection).
  std::function<void(DoorHarness&)> on_tick;

  /// Starts MotionControl (redundancy[lbl1], xr4000, puma).
  void start_motion_control() {
    ep_.activate(path("motionctrl/redundancy:lbl1"));
    for (const char* n : {"motionctrl/redundancy", "motionctrl/xr4000", "motionctrl/puma"}) run(n);
  }

  /// Runs steps [0, last] in order; returns when the last one ended, one failed, or `budget` s passed.
  DoorRunResult run_task(double budget, int last = 4) {
    DoorRunResult r;
    start_motion_control();
    const Nanos deadline = now_ + from_seconds(budget);
    r.step_start.push_back(seconds());
    start_step(steps_[0]);
    for (int i = 0; i <= last; ++i) {
      const DoorStep& s = steps_[static_cast<std::size_t>(i)];
      std::optional<std::pair<std::string, ComponentEvent>> ended;
      while (!ended && now_ < deadline) {
        tick_controllers();
        ended = step_event(s);
        events_.clear();
        if (ended && reaction == 0) break;  // the supervisor reacts at this tick, before the world steps
        tick_world();
        track(r);
      }
      // The supervisor reacts after `reaction` (the event's trip to it and its orders' trip back): until then
      // the step's other controllers keep running.
      for (const Nanos until = now_ + reaction; reaction > 0 && now_ < until;) {
        tick();
        events_.clear();
        track(r);
      }
      end_step(s);
      r.step_end.push_back(seconds());
      r.step_end_door_angle.push_back(world_.sensors().door_angle);
      const bool done = ended && ended->second.kind != ComponentEvent::Kind::Aborted;
      if (done && i < last) start_step(steps_[static_cast<std::size_t>(i + 1)]);  // at this tick too
      if (ended && reaction == 0) {
        tick_world();  // the tick of the reaction ends
        track(r);
      }
      if (!ended) {
        r.failure = s.name + ": not ended after " + std::to_string(budget) + " s of simulated time";
        break;
      }
      if (!done) {
        r.failed_instance = ended->first;
        r.abort_reason = ended->second.reason;
        r.failure = s.name + ": " + ended->first + " ABORTED: " + ended->second.reason;
        break;
      }
      ++r.steps_done;
      if (i < last) r.step_start.push_back(seconds());
    }
    // Let the robot come to rest under MotionControl (no step drives it).
    for (int k = 0; k < 100; ++k) {
      tick();
      track(r);
    }
    r.time = to_seconds(now_);
    r.door_angle = world_.sensors().door_angle * 180 / M_PI;
    return r;
  }

  /// One world period: tick_controllers, then tick_world.
  void tick() {
    tick_controllers();
    tick_world();
  }
  /// The tick's first half: deliver the samples written at the previous tick, publish the sensors, run the
  /// controllers due now.
  void tick_controllers() {
    for (auto& r : relays_)
      while (r.in->pop()) r.out->write_bytes(r.in->current_bytes());
    publish_sensors();
    timers_.advance_to(now_);
  }
  /// Its second half: the commands written at this tick act in the world's step from it to the next.
  void tick_world() {
    collect_commands();
    applied_ = staged_commands();
    world_.set_commands(applied_);
    world_.step();
    now_ += kMs;
    if (on_tick) on_tick(*this);
  }

  /// Activates a set and runs (Init + Run) the step's controllers, left to right.
  void start_step(const DoorStep& s) {
    for (const auto& set : s.sets) ep_.activate(path(set));
    for (const auto& n : s.run) run(n);
  }
  /// Stops the step's controllers and deactivates its sets.
  void end_step(const DoorStep& s) {
    for (const auto& n : s.run) controllers_.at(n)->halt();
    for (const auto& set : s.sets) ep_.deactivate(path(set));
  }
  void run(const std::string& name) {
    Controller& c = *controllers_.at(name);
    std::string err;
    if (!c.start({}, &err)) throw std::runtime_error(name + ": " + err);
  }
  /// The process of `name` dies (SIGSEGV): its connections close, nothing of it runs or writes again.
  void crash(const std::string& name) {
    ep_.remove_component(path(name));
    controllers_.erase(name);
  }
  /// Events (instance, event) since the last call, for tests driving steps themselves.
  std::vector<std::pair<std::string, ComponentEvent>> take_events() {
    auto e = std::move(events_);
    events_.clear();
    return e;
  }
  /// The latest sample written on `name`.`port` (empty before any).
  Eigen::VectorXd latest(const std::string& name, const std::string& port) {
    const Output* out = controllers_.at(name)->ports().find_output(port);
    const Bytes b = out->latest_bytes();
    Eigen::VectorXd v(static_cast<Eigen::Index>(b.size() / sizeof(double)));
    if (!b.empty()) std::memcpy(v.data(), b.data(), b.size());
    return v;
  }

 private:
  struct Relay {
    PortSet ports;
    Input* in = nullptr;
    Output* out = nullptr;
  };
  struct Held {
    Eigen::VectorXd v;
    Nanos written = -1;
  };

  /// A controller of door_open.dca: its type, its instance name (below kRoot), the arguments after the host.
  struct Instance {
    const char* type;
    const char* name;
    std::vector<std::string> params;
  };
  static std::vector<Instance> Instances() {
    return {
      // MotionControl(host1 = manipulation, host2 = platform)
      {"XR4000Ctrl", "motionctrl/xr4000", {}},
      {"Puma560Ctrl", "motionctrl/puma", {}},
      {"RedundancyResolution", "motionctrl/redundancy", {}},
      // DistDetector, HitDetector
      {"LaserSensor", "distdetect/laser", {}},
      {"DistanceThreshold", "distdetect/threshold", {}},
      {"ForceTorque", "hit/force", {}},
      {"ForceThreshold", "hit/threshold", {}},
      // DoorOpen(host3, host2)
      {"ForceTorque", "dooropen/force", {}},
      {"CompliantCtrl", "dooropen/compliant", {}},
      {"XR4000Odometry", "dooropen/xr4000", {}},
      {"Puma560Joints", "dooropen/puma", {}},
      {"ModelBasedCtrl", "dooropen/model", {}},
      {"ConfigCtrl", "dooropen/config", {}},
      {"AddVelocity", "dooropen/add", {}},
      // DoorOpenSystem
      {"HandleCamera", "camera", {}},
      {"VisualServoing", "visualserv", {}},
      {"LinearTrajectory", "approach", {}},
      {"ForceTorque", "pressft", {}},
      {"Puma560Joints", "pressjoints", {}},
      {"PressHandle", "presshandle", {}},
      {"GripperControl", "opengrip", {"open"}},
      {"GripperControl", "closegrip", {"close"}},
    };
  }
  /// A connection of door_open.dca: from.out -> to.in, in the connection set `set`.
  struct Connection {
    const char *from, *out, *to, *in, *set;
  };
  static std::vector<Connection> Connections() {
    return {
      // MotionControl(host1 = manipulation, host2 = platform)
      {"motionctrl/redundancy", "BaseVel", "motionctrl/xr4000", "Vel", "motionctrl/redundancy:lbl1"},
      {"motionctrl/redundancy", "ArmVel", "motionctrl/puma", "Vel", "motionctrl/redundancy:lbl1"},
      {"motionctrl/puma", "Joints", "motionctrl/redundancy", "Joints", "motionctrl/redundancy:lbl1"},
      // DistDetector, HitDetector
      {"distdetect/laser", "Distance", "distdetect/threshold", "Distance", "distdetect/laser:lbl1"},
      {"hit/force", "Wrench", "hit/threshold", "Wrench", "hit/force:lbl1"},
      // DoorOpen(host3, host2)
      {"dooropen/force", "Wrench", "dooropen/compliant", "Wrench", "dooropen/force:lbl1"},
      {"dooropen/compliant", "Vel", "dooropen/add", "In1", "dooropen/compliant:lbl1"},
      {"dooropen/xr4000", "Pose", "dooropen/model", "BasePose", "dooropen/xr4000:lbl1"},
      {"dooropen/puma", "Joints", "dooropen/model", "Joints", "dooropen/puma:lbl1"},
      {"dooropen/puma", "Joints", "dooropen/config", "Joints", "dooropen/puma:lbl1"},
      {"dooropen/puma", "Joints", "dooropen/compliant", "Joints", "dooropen/puma:lbl1"},
      {"dooropen/model", "Vel", "dooropen/add", "In2", "dooropen/model:lbl1"},
      {"dooropen/config", "Vel", "dooropen/add", "In3", "dooropen/config:lbl1"},
      // DoorOpenSystem: motionctrl.In is redundancy.In (external_io); dooropen.Out is add.Out.
      {"camera", "Feature", "visualserv", "Feature", "visualserv:lbl1"},
      {"visualserv", "Vel", "motionctrl/redundancy", "In", "visualserv:lbl1"},
      {"approach", "Vel", "motionctrl/redundancy", "In", "approach:lbl1"},
      {"pressft", "Wrench", "presshandle", "Wrench", "presshandle:lbl1"},
      {"pressjoints", "Joints", "presshandle", "Joints", "presshandle:lbl1"},
      {"presshandle", "Vel", "motionctrl/redundancy", "In", "presshandle:lbl1"},
      {"dooropen/add", "Out", "motionctrl/redundancy", "In", "dooropen:lbl1"},
    };
  }

  void add(const std::string& type, const std::string& name, std::vector<std::string> params = {}) {
    auto c = Registry::global().create(type, {path(name), "local", std::move(params), &timers_, nullptr});
    c->on_event = [this, name](const ComponentEvent& e) { events_.emplace_back(name, e); };
    ep_.add_component(path(name), c->ports());
    // Device ports: wired to the world's signals in the set <leaf path>:device, active for good.
    const std::string set = path(name) + ":device";
    const Manifest* m = Registry::global().manifest(type);
    for (const auto& in : m->inputs)
      if (!in.device.empty()) wire({"world", in.device, path(name), in.name, set, Mode::Push, 16});
    for (const auto& out : m->outputs)
      if (!out.device.empty()) wire({path(name), out.name, "world", out.device, set, Mode::Push, 16});
    ep_.activate(set);
    controllers_.emplace(name, std::move(c));
  }
  void wire(const ConnectRequest& r) {
    std::string err = "no answer";
    ep_.connect(r, {}, [&](const std::string& e) { err = e; });
    if (!err.empty()) throw std::runtime_error(r.from + "." + r.out + " -> " + r.to + "." + r.in + ": " + err);
  }
  /// from.out -> to.in in `set`, through a relay that delays every sample by one tick.
  void connect(const std::string& from, const std::string& out, const std::string& to, const std::string& in,
               const std::string& set) {
    const std::string full_set = path(set);
    auto& r = relays_.emplace_back();
    const std::string name = "/relay/" + std::to_string(relays_.size() - 1);
    const PortSpec& spec = controllers_.at(from)->ports().find_output(out)->spec();
    r.in = &r.ports.add_input(spec, 16);
    r.out = &r.ports.add_output(spec);
    ep_.add_component(name, r.ports);
    wire({path(from), out, name, spec.name, full_set, Mode::Push, 16});
    wire({name, spec.name, path(to), in, full_set, Mode::Push, 16});
  }

  void publish_sensors() {
    const sim::Sensors& s = world_.sensors();
    auto put = [this](const char* name, std::initializer_list<double> v) {
      Eigen::VectorXd x(static_cast<Eigen::Index>(v.size()));
      Eigen::Index i = 0;
      for (double d : v) x[i++] = d;
      world_ports_.find_output(name)->write(x);
    };
    const auto& q = s.arm_q;
    const auto& qd = s.arm_qd;
    const auto& w = s.wrench;
    put("arm.q", {q[0], q[1], q[2], q[3], q[4], q[5]});
    put("arm.qd", {qd[0], qd[1], qd[2], qd[3], qd[4], qd[5]});
    put("base.pose", {s.base_pose.x, s.base_pose.y, s.base_pose.yaw});
    put("base.vel", {s.base_vel[0], s.base_vel[1], s.base_vel[2]});
    put("wrist.wrench", {w[0], w[1], w[2], w[3], w[4], w[5]});
    put("laser.range", {s.laser_range});
    put("camera.handle", {s.camera_handle[0], s.camera_handle[1], s.camera_handle[2]});
    put("door.angle", {s.door_angle});
    put("door.handle_angle", {s.handle_angle});
    put("gripper.width", {s.gripper_width});
    put("gripper.state", {static_cast<double>(static_cast<int>(s.gripper))});
  }

  void collect_commands() {
    for (const char* n : {"base.cmd_vel", "arm.cmd_qd", "gripper.cmd"}) {
      Input* in = world_ports_.find_input(n);
      if (in->take_latest()) held_[n] = {in->vector(), now_};
    }
  }
  /// The commands for the step after this one: velocities not refreshed for `stale` count as zero.
  sim::Commands staged_commands() const {
    sim::Commands c;
    auto fresh = [this](const char* n) -> const Held* {
      auto it = held_.find(n);
      if (it == held_.end() || it->second.written < 0 || now_ - it->second.written > stale_) return nullptr;
      return &it->second;
    };
    if (const Held* h = fresh("base.cmd_vel"))
      for (int i = 0; i < 3; ++i) c.base_vel[static_cast<std::size_t>(i)] = h->v[i];
    if (const Held* h = fresh("arm.cmd_qd"))
      for (int i = 0; i < 6; ++i) c.arm_qd[static_cast<std::size_t>(i)] = h->v[i];
    auto g = held_.find("gripper.cmd");
    c.gripper_close = g != held_.end() && g->second.v.size() == 1 && g->second.v[0] > 0.5;
    return c;
  }

  /// The event that ends step `s` among those of this tick: its decider's DONE or any of its ABORTED.
  std::optional<std::pair<std::string, ComponentEvent>> step_event(const DoorStep& s) const {
    for (const auto& [who, e] : events_) {
      if (std::find(s.run.begin(), s.run.end(), who) == s.run.end()) continue;
      if (e.kind == ComponentEvent::Kind::Aborted || who == s.decider) return std::make_pair(who, e);
    }
    return std::nullopt;
  }

  void track(DoorRunResult& r) const {
    r.max_door_angle = std::max(r.max_door_angle, world_.sensors().door_angle * 180 / M_PI);
  }

  sim::World world_;
  boost::asio::io_context io_;
  TimerServer timers_{io_, ClockKind::Simulated};
  Endpoint ep_{io_, "local"};
  PortSet world_ports_;
  std::map<std::string, std::unique_ptr<Controller>> controllers_;
  std::deque<Relay> relays_;  // a deque: the endpoint holds their PortSets by reference
  std::vector<DoorStep> steps_;
  std::vector<std::pair<std::string, ComponentEvent>> events_;
  std::map<std::string, Held> held_;
  sim::Commands applied_;
  Nanos now_ = 0;
  Nanos stale_ = 50 * kMs;
};

}  // namespace dca::testing
