#include "sim/device_node.h"

#include <cstdio>
#include <stdexcept>
#include <vector>

#include "host/lockstep.h"
#include "host/net/channel.h"
#include "host/timers.h"

namespace dca::sim {

using wire::Message;
using wire::Value;

namespace {

// The world's signals as ports.
class DeviceComponent final : public Component {
 public:
  DeviceComponent(std::string name, const DeviceWorld& w) : name_(std::move(name)) {
    for (const auto& s : w.sensors()) outputs.push_back(&ports_.add_output(vector_port(s.name, s.size, s.units)));
    for (const auto& s : w.commands()) inputs.push_back(&ports_.add_input(vector_port(s.name, s.size, s.units), 16));
  }
  const std::string& name() const override { return name_; }
  PortSet& ports() override { return ports_; }
  bool configure(std::string*) override { return true; }
  bool start(Bytes, std::string*) override { return true; }
  void halt() override {}
  std::vector<Output*> outputs;  // DeviceWorld::sensors() order
  std::vector<Input*> inputs;    // DeviceWorld::commands() order

 private:
  std::string name_;
  PortSet ports_;
};

// StatusSink into a wire map.
class ValueSink final : public StatusSink {
 public:
  explicit ValueSink(Value& v) : v_(v) {}
  void number(const std::string& key, double x) override { v_.set(key, x); }
  void numbers(const std::string& key, const std::vector<double>& xs) override {
    Value::Array a;
    for (const double x : xs) a.emplace_back(x);
    v_.set(key, Value(std::move(a)));
  }
  void table(const std::string& key, const std::vector<std::pair<std::string, double>>& entries) override {
    Value m = Value::map();
    for (const auto& [k, x] : entries) m.set(k, x);
    v_.set(key, std::move(m));
  }
  void texts(const std::string& key, const std::vector<std::string>& lines) override {
    Value::Array a;
    for (const auto& l : lines) a.emplace_back(l);
    v_.set(key, Value(std::move(a)));
  }

 private:
  Value& v_;
};

}  // namespace

struct DeviceNode::Impl {
  Impl(Loop& l, DeviceWorld& w, DeviceNodeOptions o)
      : loop(l), world(w), opts(std::move(o)), clock(l, clock_options(opts, w), hooks()) {
    if (!opts.trace.empty() && !(trace = std::fopen(opts.trace.c_str(), "w")))
      throw std::runtime_error("cannot write the trace " + opts.trace);
    buffer.resize(64);
  }
  ~Impl() {
    if (trace) std::fclose(trace);
  }
  Loop& loop;
  DeviceWorld& world;
  DeviceNodeOptions opts;
  DeviceComponent* component = nullptr;
  Node* node = nullptr;
  std::FILE* trace = nullptr;
  std::vector<double> buffer;  // a sensor's values
  Lockstep clock;

  static LockstepOptions clock_options(const DeviceNodeOptions& o, const DeviceWorld& w) {
    LockstepOptions c;
    c.period = from_seconds(w.period());
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
    h.writer_gone = [this](const std::string& in) {
      for (std::size_t i = 0; i < component->inputs.size(); ++i)
        if (component->inputs[i]->name() == in) world.writer_gone(i);
    };
    h.trace = [this](const std::string& line) {
      if (!trace) return;
      if (line.empty()) std::fflush(trace);
      else std::fprintf(trace, "%s\n", line.c_str());
    };
    return h;
  }

  void step() {
    for (std::size_t i = 0; i < component->inputs.size(); ++i) {
      Input& in = *component->inputs[i];
      if (!in.take_latest()) continue;
      const auto v = in.vector();
      world.command(i, v.data(), static_cast<std::size_t>(v.size()));
    }
    world.step();
  }

  void publish() {
    const auto& sensors = world.sensors();
    for (std::size_t i = 0; i < component->outputs.size(); ++i) {
      if (buffer.size() < sensors[i].size) buffer.resize(sensors[i].size);
      world.sensor(i, buffer.data());
      component->outputs[i]->write(Eigen::Map<const Eigen::VectorXd>(buffer.data(), sensors[i].size));
    }
  }

  Value status() const {
    Value v = clock.status();
    ValueSink sink(v);
    world.status(sink);
    return v;
  }

  bool handle(const std::shared_ptr<Channel>& ch, const Message& m) {
    if (m.type == "status") return ch->reply(m, status()), true;
    if (m.type == "tap" || m.type == "record_end")
      return ch->reply_error(m, m.type + ": taps and recordings are the door world's for now (docs/robots.md)"), true;
    if (m.type == "note") return ch->reply(m, Value::map()), true;
    return clock.handle(ch, m);
  }
};

DeviceNode::DeviceNode(Loop& loop, DeviceWorld& world, DeviceNodeOptions options)
    : impl_(std::make_unique<Impl>(loop, world, std::move(options))) {
  // the run that drove time is gone: nobody will stop us, so stop (as the door world does)
  impl_->clock.on_master_lost = [this](const std::string& why) {
    std::fprintf(stderr, "dca sim: %s: the world stops\n", why.c_str());
    impl_->loop.stop();
  };
}

DeviceNode::~DeviceNode() = default;

void DeviceNode::go() { impl_->clock.go(); }

std::int64_t DeviceNode::now() const { return impl_->clock.now(); }

Value DeviceNode::status() const { return impl_->status(); }

std::unique_ptr<Node> DeviceNode::make_node(NodeOptions options) {
  if (options.type.empty()) options.type = "World";
  options.world.clear();  // the clock master is not on anyone's clock
  options.gated = true;   // but its inputs take their samples in lock-step
  options.stamp_clock = [this] { return impl_->clock.now(); };
  auto node = std::make_unique<Node>(
      impl_->loop, std::move(options),
      [this](const std::string&, const std::string& name, const std::string&, const std::vector<std::string>&,
             TimerServer&) {
        auto c = std::make_unique<DeviceComponent>(name, impl_->world);
        impl_->component = c.get();
        return std::unique_ptr<Component>(std::move(c));
      });
  node->on_request([this](const std::shared_ptr<Channel>& ch, const Message& m) { return impl_->handle(ch, m); });
  impl_->node = node.get();
  return node;
}

}  // namespace dca::sim
