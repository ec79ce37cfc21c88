// Boost.Asio 1.74 under GCC 12 -O3 trips middle-end warnings inside its own headers (false positives).
#pragma GCC diagnostic ignored "-Wnull-dereference"
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"

#include "sim/world_node.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <optional>

#include <boost/asio/post.hpp>
#include <boost/asio/steady_timer.hpp>

#include "host/channel.h"
#include "host/timers.h"
#include "sim/recorder.h"

namespace dca::sim {

using wire::Message;
using wire::Value;

namespace {

// The world's signals as ports (names and sizes: sim/world.h).
struct Signal {
  const char* name;
  std::uint32_t size;
  const char* units;
};
constexpr Signal kOutputs[] = {
    {"arm.q", 6, "rad"},           {"arm.qd", 6, "rad/s"},         {"base.pose", 3, "m, m, rad"},
    {"base.vel", 3, "m/s, m/s, rad/s"}, {"wrist.wrench", 6, "N, N m"}, {"laser.range", 1, "m"},
    {"camera.handle", 3, "px, px, 1"}, {"door.angle", 1, "rad"},    {"door.handle_angle", 1, "rad"},
    {"gripper.width", 1, "m"},     {"gripper.state", 1, "0 open, 1 closed, 2 moving, 3 grasping"},
};
constexpr Signal kInputs[] = {
    {"base.cmd_vel", 3, "m/s, m/s, rad/s"}, {"arm.cmd_qd", 6, "rad/s"}, {"gripper.cmd", 1, "0 open, 1 close"}};

class WorldComponent final : public Component {
 public:
  explicit WorldComponent(std::string name) : name_(std::move(name)) {
    for (const auto& s : kOutputs) outputs.push_back(&ports_.add_output(vector_port(s.name, s.size, s.units)));
    for (const auto& s : kInputs) inputs.push_back(&ports_.add_input(vector_port(s.name, s.size, s.units), 16));
  }
  const std::string& name() const override { return name_; }
  PortSet& ports() override { return ports_; }
  std::string init() override { return ""; }
  std::string run(Bytes) override { return ""; }
  void stop() override {}
  std::vector<Output*> outputs;  // kOutputs order
  std::vector<Input*> inputs;    // kInputs order

 private:
  std::string name_;
  PortSet ports_;
};

Value array_of(const double* v, int n) {
  Value a = Value::array();
  for (int i = 0; i < n; ++i) a.array_ref().push_back(Value(v[i]));
  return a;
}

}  // namespace

struct WorldNode::Impl {
  Impl(Loop& l, World& w, WorldNodeOptions o)
      : loop(l), world(w), opts(std::move(o)), timer(l.io()) {
    period = from_seconds(world.config().period);
    sync = std::max<Nanos>(period, from_seconds(opts.sync_period));
    sync = (sync / period) * period;  // a multiple of the period, so sync ticks happen
    if (!opts.record.empty()) {
      recorder = std::make_unique<Recorder>(opts.record);
      record_every = std::max<long>(1, std::lround(opts.record_period / world.config().period));
      recorder->record(world.sensors(), -1);
    }
  }
  Loop& loop;
  World& world;
  WorldNodeOptions opts;
  WorldComponent* component = nullptr;
  std::unique_ptr<Recorder> recorder;
  long record_every = 1;
  boost::asio::steady_timer timer;
  std::shared_ptr<bool> alive = std::make_shared<bool>(true);

  struct Subscriber {
    std::shared_ptr<Channel> ch;
    std::string name;
    std::optional<Nanos> next;
  };
  std::map<std::uint64_t, Subscriber> subs;
  std::uint64_t next_sub = 1;
  std::vector<std::string> dropped;

  Nanos period = 1000000, sync = 10000000;
  long steps = 0;
  bool running = false, scheduled = false, duration_hit = false;
  int waiting = 0;  // advances not yet answered
  Commands cmd;
  Nanos base_at = -1, arm_at = -1;  // when the last base / arm command arrived
  std::chrono::steady_clock::time_point wall0;
  double wall_s = 0;  // wall time while running
  // Wall time of each lock-step round (advances sent -> last reply, drained): what a simulated control period
  // costs in real time.
  LatenessHistogram rounds;
  std::chrono::steady_clock::time_point round0;
  Nanos round_sim = 0;      // simulated time of the rounds' ticks
  std::uint64_t ticked = 0;  // subscriber advances answered

  Nanos now() const { return steps * period; }

  void drop(std::uint64_t id, const std::string& why) {
    auto it = subs.find(id);
    if (it == subs.end()) return;
    const std::string msg = it->second.name + ": " + why;
    std::fprintf(stderr, "dca sim: dropped from the clock: %s\n", msg.c_str());
    dropped.push_back(msg);
    subs.erase(it);
  }

  void take_commands() {
    const Nanos t = now();
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
      component->outputs[i]->write(Eigen::Map<const Eigen::VectorXd>(data[i], kOutputs[i].size));
  }

  void schedule() {
    if (scheduled || !running || waiting > 0) return;
    scheduled = true;
    std::weak_ptr<bool> a = alive;
    if (opts.realtime) {
      const auto due = wall0 + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                   std::chrono::nanoseconds(now() + period));
      timer.expires_at(due);
      timer.async_wait([this, a](const boost::system::error_code& ec) {
        if (ec || a.expired()) return;
        scheduled = false;
        tick();
      });
    } else {
      boost::asio::post(loop.io(), [this, a] {
        if (a.expired()) return;
        scheduled = false;
        tick();
      });
    }
  }

  void tick() {
    if (!running || waiting > 0 || !component) return;
    const auto w0 = std::chrono::steady_clock::now();
    take_commands();
    world.step();
    ++steps;
    const Nanos t = now();
    if (recorder && steps % record_every == 0) recorder->record(world.sensors(), -1);
    std::vector<std::uint64_t> due;
    const bool sync_tick = t % sync == 0;
    for (const auto& [id, s] : subs)
      if (sync_tick || (s.next && *s.next <= t)) due.push_back(id);
    if (sync_tick || !due.empty()) {
      publish();
      loop.settle();  // the sensor samples are on their way before anyone is told to tick
    }
    wall_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - w0).count();
    if (opts.duration >= 0 && t >= from_seconds(opts.duration) && !duration_hit) {
      duration_hit = true;
      running = false;
    }
    if (due.empty()) return after_tick();
    waiting = static_cast<int>(due.size()) + 1;
    round0 = std::chrono::steady_clock::now();
    const auto timeout = std::chrono::milliseconds(opts.tick_timeout_ms);
    std::weak_ptr<bool> a = alive;
    for (const auto id : due) {
      auto it = subs.find(id);
      if (it == subs.end()) {
        --waiting;
        continue;
      }
      it->second.ch->request({"advance", 0, Value::map().set("t", t)}, timeout, [this, a, id, t](Response r) {
        if (a.expired()) return;
        if (!r.ok()) {
          drop(id, r.replied() ? "advance to " + std::to_string(to_seconds(t)) + " s refused: " + r.error
                               : "did not answer the advance to " + std::to_string(to_seconds(t)) + " s (" +
                                     r.error + ")");
        } else {
          ++ticked;
          if (auto it2 = subs.find(id); it2 != subs.end()) {
            const auto& n = r.message.payload["next"];
            it2->second.next = n.is_nil() ? std::nullopt : std::optional<Nanos>(n.as_int(0));
          }
        }
        if (--waiting == 0) {
          rounds.record(std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now() - round0).count());
          after_tick();
        }
      });
    }
    if (--waiting == 0) after_tick();
  }

  void after_tick() {
    loop.settle();  // take in the commands the nodes wrote at this tick
    if (duration_hit && on_duration_pending) {
      on_duration_pending = false;
      if (on_duration) on_duration();
    }
    schedule();
  }
  bool on_duration_pending = true;
  std::function<void()> on_duration;

  void start() {
    if (running) return;
    running = true;
    // paced to the wall clock: its ticks wake on time (1 ns timer slack, as dca's wall-clock timers have,
    // instead of the default 50 µs that would add to every control period of the nodes on its clock)
    if (opts.realtime) minimise_timer_slack();
    wall0 = std::chrono::steady_clock::now() - std::chrono::nanoseconds(now());
    schedule();
  }

  Value status() const {
    const Sensors& s = world.sensors();
    Value names = Value::array(), drops = Value::array();
    for (const auto& [id, sub] : subs) names.array_ref().push_back(Value(sub.name));
    for (const auto& d : dropped) drops.array_ref().push_back(Value(d));
    const double pose[3] = {s.base_pose.x, s.base_pose.y, s.base_pose.yaw};
    return Value::map()
        .set("now", now())
        .set("t", to_seconds(now()))
        .set("running", running)
        .set("steps", static_cast<std::int64_t>(steps))
        .set("wall_s", wall_s)
        .set("subscribers", names)
        .set("dropped", drops)
        .set("door_angle", s.door_angle)
        .set("handle_angle", s.handle_angle)
        .set("gripper_state", static_cast<std::int64_t>(static_cast<int>(s.gripper)))
        .set("base_pose", array_of(pose, 3))
        .set("rounds", static_cast<std::int64_t>(rounds.count()))
        .set("advances", static_cast<std::int64_t>(ticked))
        .set("round_p50_us", static_cast<double>(rounds.quantile(0.5)) / 1000.0)
        .set("round_p99_us", static_cast<double>(rounds.quantile(0.99)) / 1000.0)
        .set("round_max_us", static_cast<double>(rounds.max()) / 1000.0)
        .set("latched", world.latched())
        .set("grasping", world.grasping());
  }
};

WorldNode::WorldNode(Loop& loop, World& world, WorldNodeOptions options)
    : impl_(std::make_unique<Impl>(loop, world, std::move(options))) {}

WorldNode::~WorldNode() {
  if (impl_->recorder) {
    try {
      impl_->recorder->close();
    } catch (const std::exception& e) {
      std::fprintf(stderr, "dca sim: %s\n", e.what());
    }
  }
}

std::unique_ptr<Component> WorldNode::make_component(const std::string& name) {
  auto c = std::make_unique<WorldComponent>(name);
  impl_->component = c.get();
  return c;
}

void WorldNode::go() {
  impl_->on_duration = on_duration;
  impl_->start();
}

std::int64_t WorldNode::now() const { return impl_->now(); }

std::unique_ptr<Node> WorldNode::make_node(NodeOptions options) {
  if (options.type.empty()) options.type = "World";
  options.world.clear();  // the clock master is not on anyone's clock
  auto node = std::make_unique<Node>(
      impl_->loop, std::move(options),
      [this](const std::string&, const std::string& name, const std::string&, const std::vector<std::string>&,
             TimerServer&) { return make_component(name); });
  node->on_request([this](const std::shared_ptr<Channel>& ch, const Message& m) { return handle(ch, m); });
  return node;
}

bool WorldNode::handle(const std::shared_ptr<Channel>& ch, const Message& m) {
  auto& I = *impl_;
  if (m.type == "clock") {
    const std::string name = m.payload["name"].as_string();
    if (name.empty()) return ch->reply_error(m, "clock needs the subscriber's name"), true;
    for (auto it = I.subs.begin(); it != I.subs.end();)
      it = it->second.ch == ch ? I.subs.erase(it) : std::next(it);
    I.subs[I.next_sub++] = {ch, name, std::nullopt};
    ch->reply(m, Value::map().set("now", I.now()));
    return true;
  }
  if (m.type == "go") {
    I.on_duration = on_duration;
    I.start();
    ch->reply(m, Value::map().set("now", I.now()));
    return true;
  }
  if (m.type == "hold") {
    I.running = false;
    ch->reply(m, Value::map().set("now", I.now()));
    return true;
  }
  if (m.type == "status") {
    ch->reply(m, I.status());
    return true;
  }
  return false;
}

}  // namespace dca::sim
