#include "sim/world_node.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <stdexcept>

#include "host/lockstep.h"
#include "host/net/channel.h"
#include "host/net/tap.h"
#include "host/timers.h"
#include "sim/recorder.h"
#include "sim/world_taps.h"

namespace dca::sim {

using wire::Message;
using wire::Value;

namespace {

// The world's signals (sim/world.h) as ports.
class WorldComponent final : public Component {
 public:
  explicit WorldComponent(std::string name) : name_(std::move(name)) {
    for (const auto& s : kSensorSignals)
      outputs.push_back(&ports_.add_output(vector_port(s.name, s.size, s.units)));
    for (const auto& s : kCommandSignals)
      inputs.push_back(&ports_.add_input(vector_port(s.name, s.size, s.units), 16));
  }
  const std::string& name() const override { return name_; }
  PortSet& ports() override { return ports_; }
  bool configure(std::string*) override { return true; }
  bool start(Bytes, std::string*) override { return true; }
  void halt() override {}
  std::vector<Output*> outputs;  // kSensorSignals order
  std::vector<Input*> inputs;    // kCommandSignals order

 private:
  std::string name_;
  PortSet ports_;

 public:
  tap::Taps taps{ports_};  // inputs "tap:PATH" (host/net/tap.h), added by `tap` requests
};

}  // namespace

struct WorldNode::Impl {
  Impl(Loop& l, World& w, WorldNodeOptions o)
      : loop(l), world(w), opts(std::move(o)), clock(l, clock_options(opts, world), hooks()),
        taps(clock, opts.record.empty() ? nullptr : std::make_unique<Recorder>(opts.record)) {
    if (taps.recorder()) {
      record_every = std::max<long>(1, std::lround(opts.record_period / world.config().period));
      taps.recorder()->record(world.sensors(), -1);
    }
    if (!opts.trace.empty() && !(trace = std::fopen(opts.trace.c_str(), "w")))
      throw std::runtime_error("cannot write the trace " + opts.trace);
  }
  ~Impl() {
    if (trace) std::fclose(trace);
  }
  Loop& loop;
  World& world;
  WorldNodeOptions opts;
  WorldComponent* component = nullptr;
  Node* node = nullptr;  // the node that hosts the component (its data endpoint: lock-step counts)
  std::FILE* trace = nullptr;
  long record_every = 1;
  long steps = 0;
  Commands cmd;
  Commands applied;  // what the last step applied (the watchdog's zeros in)
  Nanos base_at = -1, arm_at = -1;  // when the last base / arm command arrived
  Lockstep clock;
  WorldTaps taps;  // tap, record_end, note; the recording

  static LockstepOptions clock_options(const WorldNodeOptions& o, const World& w) {
    LockstepOptions c;
    c.period = from_seconds(w.config().period);
    c.sync_period = o.sync_period;
    c.tick_timeout_ms = o.tick_timeout_ms;
    c.realtime = o.realtime;
    c.duration = o.duration;
    c.log_name = "dca sim";
    c.trace = !o.trace.empty();
    return c;
  }

  LockstepHooks hooks() {
    LockstepHooks h;
    h.ready = [this] { return component != nullptr && node != nullptr; };
    h.step = [this] { step(); };
    h.publish = [this] { publish(); };
    h.sent = [this] { return node->sent_changes(); };
    h.take = [this](const Value& expect) { return node->take_expected(expect); };
    h.digests = [this] { return node->digests(); };
    h.writer_gone = [this](const std::string& in) { writer_gone(in); };
    h.trace = [this](const std::string& line) {
      if (!trace) return;
      if (line.empty()) std::fflush(trace);
      else std::fprintf(trace, "%s\n", line.c_str());
    };
    return h;
  }

  // One period: the tapped samples written before it recorded (at their writers' ticks), the commands that
  // arrived applied, the world steps, every record_every steps a row.
  void step() {
    taps.record_taps();
    take_commands();
    world.step();
    ++steps;
    if (taps.recorder() && steps % record_every == 0) taps.recorder()->record(world.sensors(), -1);
  }

  void take_commands() {
    const Nanos t = clock.now();
    if (component->inputs[0]->take_latest() && component->inputs[0]->vector().size() == 3) {
      const auto v = component->inputs[0]->vector();
      for (int i = 0; i < 3; ++i) cmd.base_vel[i] = v[i];
      base_at = t;
    }
    if (component->inputs[1]->take_latest() && component->inputs[1]->vector().size() == 6) {
      const auto v = component->inputs[1]->vector();
      for (int i = 0; i < 6; ++i) cmd.arm_qd[i] = v[i];
      arm_at = t;
    }
    if (component->inputs[2]->take_latest() && component->inputs[2]->vector().size() == 1)
      cmd.gripper_close = component->inputs[2]->vector()[0] > 0.5;
    const Nanos stale = from_seconds(opts.command_timeout);
    Commands c = cmd;
    if (base_at < 0 || t - base_at > stale) c.base_vel = {};
    if (arm_at < 0 || t - arm_at > stale) c.arm_qd = {};
    world.set_commands(c);
    applied = c;
  }

  // A drive command's writer is lost or restarted (at this tick): the drive stops at once, as a robot's driver
  // does on losing its writer, until the new writer's first command. The gripper keeps its position command.
  void writer_gone(const std::string& in) {
    if (in == kCommandSignals[0].name) cmd.base_vel = {}, base_at = -1;
    if (in == kCommandSignals[1].name) cmd.arm_qd = {}, arm_at = -1;
  }

  void publish() {
    const Sensors& s = world.sensors();
    const double pose[3] = {s.base_pose.x, s.base_pose.y, s.base_pose.yaw};
    const double laser = s.laser_range, door = s.door_angle, handle = s.handle_angle, width = s.gripper_width;
    const double grip = static_cast<double>(static_cast<int>(s.gripper));
    const double* data[] = {s.arm_q.data(),  s.arm_qd.data(),        pose,    s.base_vel.data(),
                            s.wrench.data(), &laser, s.camera_handle.data(), &door,   &handle,
                            &width,          &grip};
    for (std::size_t i = 0; i < component->outputs.size(); ++i)
      component->outputs[i]->write(Eigen::Map<const Eigen::VectorXd>(data[i], kSensorSignals[i].size));
  }

  template <std::size_t N>
  static Value array_of(const std::array<double, N>& a) {
    Value::Array v;
    for (const double x : a) v.emplace_back(x);
    return Value(std::move(v));
  }

  // The clock's status and the world's state.
  Value status() const {
    const Sensors& s = world.sensors();
    Value v = clock.status();
    v.set("door_angle", s.door_angle)
        .set("handle_angle", s.handle_angle)
        .set("gripper_state", static_cast<std::int64_t>(static_cast<int>(s.gripper)))
        .set("base_pose", Value::Array{Value(s.base_pose.x), Value(s.base_pose.y), Value(s.base_pose.yaw)})
        .set("base_vel", array_of(s.base_vel))
        .set("base_cmd", array_of(applied.base_vel))  // the commands the last step applied
        .set("arm_cmd", array_of(applied.arm_qd))
        .set("arm_q", array_of(s.arm_q))
        .set("arm_qd", array_of(s.arm_qd))
        .set("latched", world.latched())
        .set("grasping", world.grasping());
    return v;
  }
};

WorldNode::WorldNode(Loop& loop, World& world, WorldNodeOptions options)
    : impl_(std::make_unique<Impl>(loop, world, std::move(options))) {
  impl_->clock.on_duration = [this] {
    if (on_duration) on_duration();
  };
  // the run that drove time is gone (its root killed, its host lost): nobody will stop us, so stop
  impl_->clock.on_master_lost = [this](const std::string& why) {
    std::fprintf(stderr, "dca sim: %s: the world stops\n", why.c_str());
    impl_->loop.stop();
  };
}

WorldNode::~WorldNode() = default;

std::unique_ptr<Component> WorldNode::make_component(const std::string& name) {
  auto c = std::make_unique<WorldComponent>(name);
  impl_->component = c.get();
  impl_->taps.attach(&c->taps);
  return c;
}

void WorldNode::go() { impl_->clock.go(); }

std::int64_t WorldNode::now() const { return impl_->clock.now(); }

std::unique_ptr<Node> WorldNode::make_node(NodeOptions options) {
  if (options.type.empty()) options.type = "World";
  options.world.clear();  // the clock master is not on anyone's clock
  options.gated = true;   // but its inputs take their samples in lock-step
  options.stamp_clock = [this] { return impl_->clock.now(); };  // a tap of its signals: at simulated time
  auto node = std::make_unique<Node>(
      impl_->loop, std::move(options),
      [this](const std::string&, const std::string& name, const std::string&, const std::vector<std::string>&,
             TimerServer&) { return make_component(name); });
  node->on_request([this](const std::shared_ptr<Channel>& ch, const Message& m) { return handle(ch, m); });
  impl_->node = node.get();
  return node;
}

bool WorldNode::handle(const std::shared_ptr<Channel>& ch, const Message& m) {
  if (m.type == "status") return ch->reply(m, impl_->status()), true;
  // tap, record_end, and note: a line of the run for the recording (dca.launch.sim), at simulated time t
  if (impl_->taps.handle(ch, m, impl_->world.time())) return true;
  return impl_->clock.handle(ch, m);
}

}  // namespace dca::sim
