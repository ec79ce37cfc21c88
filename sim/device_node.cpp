#include "sim/device_node.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <deque>
#include <map>
#include <stdexcept>
#include <vector>

#include "host/codec/frames.h"
#include "host/codec/json.h"
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

// The world's signals as ports.
class DeviceComponent final : public Component {
 public:
  DeviceComponent(std::string name, const DeviceWorld& w) : name_(std::move(name)) {
    for (const auto& s : w.sensors()) outputs.push_back(&ports_.add_output(vector_port(s.name, s.size, s.units)));
    for (const auto& s : w.commands()) inputs.push_back(&ports_.add_input(vector_port(s.name, s.size, s.units), 16));
    for (const auto& p : w.recorded_ports()) replayed.push_back(&ports_.add_output(vector_port("replay:" + p.path, p.size)));
    estop = &ports_.add_input(vector_port(kEstopInput, 1, ""), 4);
  }
  const std::string& name() const override { return name_; }
  PortSet& ports() override { return ports_; }
  bool configure(std::string*) override { return true; }
  bool start(Bytes, std::string*) override { return true; }
  void halt() override {}
  std::vector<Output*> outputs;  // DeviceWorld::sensors() order
  std::vector<Input*> inputs;    // DeviceWorld::commands() order
  std::vector<Output*> replayed; // DeviceWorld::recorded_ports() order: "replay:PATH"
  Input* estop = nullptr;        // kEstopInput: a sample above 0.5 presses the emergency stop

 private:
  std::string name_;
  PortSet ports_;

 public:
  tap::Taps taps{ports_};  // inputs "tap:PATH" (host/net/tap.h), added by `tap` requests
};

// The recording's topic of the world's signal `name`: the topic a live viewer sees it under ("/world/joint/J/position").
std::string signal_topic(const std::string& name) { return tap::topic_of("world." + name); }

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
  void flag(const std::string& key, bool x) override { v_.set(key, x); }
  void integer(const std::string& key, std::int64_t x) override { v_.set(key, x); }

 private:
  Value& v_;
};

}  // namespace

struct DeviceNode::Impl {
  Impl(Loop& l, DeviceWorld& w, DeviceNodeOptions o)
      : loop(l), world(w), opts(std::move(o)), clock(l, clock_options(opts, w), hooks()),
        taps(clock, make_recorder(opts.record, w, &own_format)) {
    if (!opts.trace.empty() && !(trace = std::fopen(opts.trace.c_str(), "w")))
      throw std::runtime_error("cannot write the trace " + opts.trace);
    buffer.resize(64);
    if (opts.blackbox && !(taps.recorder() && taps.recorder()->blackbox(opts.box)))
      throw std::runtime_error(opts.record + ": a black box records MCAP only (FILE.mcap)");
    if (taps.recorder()) taps.recorder()->configure(opts.recording);
    if (taps.recorder()) start_recording();
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
  bool own_format = false;  // the world records itself (DeviceWorld::own_recorder)
  Lockstep clock;
  std::string stuck;  // DeviceNode::stuck
  WorldTaps taps;  // tap, record_end, note; the recording
  std::vector<std::uint16_t> channels;  // each sensor's recording channel
  std::uint16_t outputs_channel = 0;     // /dca/world/outputs (record_outputs)
  std::string outputs_json;              // a message of it
  long record_every = 1, steps = 0;
  bool holding = false;  // the node's endpoint holds back the samples to clocked nodes (publish)
  std::map<std::string, std::uint64_t> refused;  // a command input's samples refused from a second writer
  std::vector<std::string> second_writers;       // each (input, writer, holder) once: what was said
  std::vector<std::weak_ptr<Channel>> supervisors;  // the supervisors on the clock: told of each second writer
  std::vector<std::size_t> replay_next;          // each recorded port's next sample to write
  long clamps_sensor = -1;                       // watch_clamps: the index of "safety.clamps" (size(): none)
  std::deque<std::pair<double, double>> clamp_history;  // (t, clamps so far) over the storm's window
  bool in_storm = false;
  std::uint64_t replay_written = 0;
  // The emergency stop (docs/safety.md, "Emergency stop").
  struct Estop {
    bool latched = false;
    double t = 0;                        // s: the last press or release
    std::string source;                  // who pressed it last
    std::uint64_t presses = 0, held = 0; // held: command samples that came while latched, not applied
    std::vector<std::uint64_t> seen;     // each command input's samples so far
    std::vector<std::string> log;        // "pressed at T s by SOURCE", "released at ..." (bounded)
    std::vector<std::weak_ptr<Channel>> watchers;  // told each press and release (`estop_watch`)
  } estop;

  // The recording of `path` ("" none): the world's own format, else the generic MCAP.
  static std::unique_ptr<Recorder> make_recorder(const std::string& path, DeviceWorld& w, bool* own) {
    if (path.empty()) return nullptr;
    if (auto r = w.own_recorder(path)) {
      *own = true;
      return r;
    }
    return std::make_unique<Recorder>(path);
  }

  static LockstepOptions clock_options(const DeviceNodeOptions& o, const DeviceWorld& w) {
    LockstepOptions c;
    c.period = from_seconds(w.period());
    c.sync_period = o.sync_period;
    c.tick_timeout_ms = o.tick_timeout_ms;
    c.spin_us = o.spin_us;
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
    h.release = [this](const std::vector<std::string>& leaves) { node->release_sends(leaves); };
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

  // The recording's channels: one per sensor signal, as its live topic (the link frames as
  // foxglove.FrameTransforms), the URDF on /robot_description (once, at time 0); then the signals at 0.
  void start_recording() {
    record_every = std::max<long>(1, std::lround(opts.record_period / world.period()));
    if (opts.record_outputs && taps.recorder()->mcap()) start_outputs(*taps.recorder());
    if (own_format) return world.record(*taps.recorder());
    Recorder& r = *taps.recorder();
    for (const auto& sig : world.sensors()) {
      if (is_frames(sig)) {
        channels.push_back(r.add_channel(signal_topic(sig.name), frames::json_schema(), frames::kSchemaName));
        continue;
      }
      const std::string topic = signal_topic(sig.name);
      channels.push_back(r.add_channel(topic, tap::json_schema(topic, vector_port(sig.name, sig.size, sig.units))));
    }
    if (const std::string urdf = world.robot_description(); !urdf.empty())
      r.write(r.add_channel(frames::kDescriptionTopic, frames::description_schema(), frames::kDescriptionSchemaName),
              0, frames::description_message(urdf));
    record_sensors();
  }

  // record_outputs: the world's signals at time 0 on /dca/world/signals ({period, sensors, commands}, each signal
  // {name, size, units}), and the channel of the outputs: at time 0 as they stand before the first publish (the
  // start a replay's world takes, so that its own recording of time 0 is the recorded one), then as published.
  void start_outputs(Recorder& r) {
    const auto list = [](const std::vector<DeviceSignal>& sigs) {
      Value a = Value::array();
      for (const auto& s : sigs)
        a.array_ref().push_back(Value::map().set("name", s.name).set("size", std::int64_t{s.size}).set("units", s.units));
      return a;
    };
    const Value v = Value::map().set("period", world.period()).set("sensors", list(world.sensors()))
                        .set("commands", list(world.commands()));
    r.write(r.add_channel("/dca/world/signals", "{\"type\":\"object\"}"), 0, json::encode(v));
    outputs_channel = r.add_channel("/dca/world/outputs", "{\"type\":\"object\",\"properties\":{\"values\":"
                                    "{\"type\":\"array\",\"description\":\"each sensor's values, in order\"}}}");
    record_outputs();
  }

  // record_outputs: the outputs as just published, {"values": [[...], ...]} at the world's time.
  void record_outputs() {
    const auto& sensors = world.sensors();
    outputs_json = "{\"values\":[";
    for (std::size_t i = 0; i < sensors.size(); ++i) {
      if (buffer.size() < sensors[i].size) buffer.resize(sensors[i].size);
      world.sensor(i, buffer.data());
      outputs_json += i ? ",[" : "[";
      for (std::uint32_t k = 0; k < sensors[i].size; ++k) {
        if (k) outputs_json += ',';
        json::append_number(outputs_json, buffer[k]);
      }
      outputs_json += ']';
    }
    outputs_json += "]}";
    taps.recorder()->write(outputs_channel, std::llround(world.time() * 1e9), outputs_json);
  }

  // The output that holds the world's link frames.
  bool is_frames(const DeviceSignal& sig) const { return sig.name == "links.frames" && !world.frames().empty(); }

  // Every sensor signal at the world's time: {"value": [...]}, as a tap of it would record it; the link frames
  // as foxglove.FrameTransforms.
  void record_sensors() {
    const auto& sensors = world.sensors();
    const auto t = static_cast<std::int64_t>(std::llround(world.time() * 1e9));
    for (std::size_t i = 0; i < sensors.size(); ++i) {
      if (buffer.size() < sensors[i].size) buffer.resize(sensors[i].size);
      world.sensor(i, buffer.data());
      if (is_frames(sensors[i])) {
        taps.recorder()->write(channels[i], t, frames::message(world.frames(), t, buffer.data(), sensors[i].size));
        continue;
      }
      std::string json = "{\"value\":[";
      for (std::uint32_t k = 0; k < sensors[i].size; ++k) {
        if (k) json += ',';
        json::append_number(json, buffer[k]);
      }
      taps.recorder()->write(channels[i], t, json + "]}");
    }
  }

  // robot_description {}: what viewers draw the robot from: {urdf, frames = [[parent, child], ...], port}.
  Value description() const {
    Value fs = Value::array();
    for (const auto& f : world.frames()) fs.array_ref().push_back(Value(Value::Array{Value(f.parent), Value(f.child)}));
    return Value::map().set("urdf", world.robot_description()).set("frames", std::move(fs)).set("port", "links.frames");
  }

  // Every command input takes one writer at a time (Input::set_exclusive): the lease in ticks.
  void exclusive_inputs() {
    const auto lease = static_cast<std::uint32_t>(std::max<long>(1, std::lround(opts.writer_lease / world.period())));
    for (Input* in : component->inputs) {
      in->set_exclusive(lease);
      in->on_refused = [this, in](const std::string& writer, const std::string& holder) {
        refused_writer(in->name(), writer, holder);
      };
    }
    // the inputs of one actuator share its hold (DeviceSignal::actuator)
    const auto& commands = world.commands();
    for (std::size_t i = 0; i < commands.size() && i < component->inputs.size(); ++i) {
      std::size_t j = 0;
      while (j < commands.size() && (commands[i].actuator.empty() || commands[j].name != commands[i].actuator)) ++j;
      if (j < component->inputs.size() && j != i) component->inputs[i]->share_exclusive(*component->inputs[j]);
    }
  }

  void refused_writer(const std::string& input, const std::string& writer, const std::string& holder) {
    ++refused[input];
    clock.note("W world." + input + " refused=" + writer + " holder=" + holder);
    const std::string who = input + ": " + writer + " refused, held by " + holder + " at ";
    for (const auto& s : second_writers)
      if (s.rfind(who, 0) == 0) return;
    if (second_writers.size() >= 64) return;  // bounded: the counts go on
    char at[32];
    std::snprintf(at, sizeof at, "%.3f s", to_seconds(clock.now()));
    second_writers.push_back(who + at);
    std::fprintf(stderr, "dca sim: a second writer on %s\n", second_writers.back().c_str());
    tell_second_writer(input, writer, holder);
    // a black box's trigger: the first refusal of this writer, holder and input
    if (opts.blackbox && taps.recorder())
      taps.recorder()->trigger(world.time(), "a second writer on " + who.substr(0, who.size() - 4));
  }

  // A storm of limit clamps (BlackboxOptions::storm_clamps within storm_window): the black box's trigger, once
  // per storm. The clamps are the world's "safety.clamps" sensor (per command input, counted since the start).
  void watch_clamps() {
    if (!opts.blackbox || !taps.recorder()) return;
    if (clamps_sensor < 0) {
      clamps_sensor = static_cast<long>(world.sensors().size());
      for (std::size_t i = 0; i < world.sensors().size(); ++i)
        if (world.sensors()[i].name == "safety.clamps") clamps_sensor = static_cast<long>(i);
    }
    const auto i = static_cast<std::size_t>(clamps_sensor);
    if (i >= world.sensors().size()) return;
    buffer.resize(std::max<std::size_t>(buffer.size(), world.sensors()[i].size));
    world.sensor(i, buffer.data());
    double sum = 0;
    for (std::uint32_t k = 0; k < world.sensors()[i].size; ++k) sum += buffer[k];
    const double t = world.time();
    clamp_history.emplace_back(t, sum);
    // the count at the window's start: the last entry at or before t - window (nothing clamped before the first)
    while (clamp_history.size() > 1 && clamp_history[1].first <= t - opts.box.storm_window + 1e-9)
      clamp_history.pop_front();
    const double base = clamp_history.front().first <= t - opts.box.storm_window + 1e-9 ? clamp_history.front().second : 0;
    const bool storm = sum - base >= static_cast<double>(opts.box.storm_clamps);
    if (storm && !in_storm) {
      char why[128];
      std::snprintf(why, sizeof why, "a storm of limit clamps: %.0f within %g s", sum - base, opts.box.storm_window);
      std::fprintf(stderr, "dca sim: %s at %.3f s\n", why, t);
      taps.recorder()->trigger(t, why);
    }
    in_storm = storm;
  }

  // A source's name as said in lines: bounded, printable.
  static std::string source_name(const std::string& s) {
    std::string out = s.empty() ? "request" : s.substr(0, 64);
    for (char& c : out)
      if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = '?';
    return out;
  }

  // Each press and release: traced, said on stderr, logged for the summary, told to the watchers.
  void estop_changed(const char* what) {
    char line[160];
    std::snprintf(line, sizeof line, "%s at %.3f s by %s", what, estop.t, estop.source.c_str());
    if (estop.log.size() < 64) estop.log.emplace_back(line);
    clock.note(std::string("E world.") + kEstopInput + " " + what + " by=" + estop.source);
    std::fprintf(stderr, "dca sim: emergency stop %s\n", line);
    const Value ev = Value::map().set("latched", estop.latched).set("t", estop.t).set("source", estop.source);
    std::erase_if(estop.watchers, [&](const std::weak_ptr<Channel>& w) {
      const auto ch = w.lock();
      return !ch || !ch->send(Message{"estop", 0, ev});
    });
  }

  // Pressed (latched): from this tick on no command sample reaches the world, which holds every actuator
  // stopped. False when it was latched already.
  bool press(const std::string& source) {
    if (estop.latched) return false;
    estop.latched = true;
    world.estop(true);
    ++estop.presses;
    estop.t = to_seconds(clock.now());
    estop.source = source_name(source);
    estop_changed("pressed");
    if (opts.blackbox && taps.recorder()) taps.recorder()->trigger(estop.t, "emergency stop by " + estop.source);
    return true;
  }

  // Released by a command that names it: "" or why not.
  std::string release(const std::string& source) {
    if (!estop.latched) return "the emergency stop is not pressed";
    Input* in = component ? component->estop : nullptr;
    if (in && in->has_current() && in->vector().size() == 1 && in->vector()[0] > 0.5)
      return std::string("the emergency stop's input world.") + kEstopInput + " still reads pressed";
    estop.latched = false;
    world.estop(false);
    estop.t = to_seconds(clock.now());
    estop.source = source_name(source);
    estop_changed("released");
    return "";
  }

  // The command samples taken in before a step: to the world, or while latched kept from it (counted).
  void take_commands() {
    Input* button = component->estop;
    if (button->take_latest() && button->vector().size() == 1 && button->vector()[0] > 0.5) press("input");
    estop.seen.resize(component->inputs.size(), 0);
    for (std::size_t i = 0; i < component->inputs.size(); ++i) {
      Input& in = *component->inputs[i];
      const std::uint64_t n = in.stats().samples;
      if (estop.latched) estop.held += n - estop.seen[i];
      estop.seen[i] = n;
      if (!in.take_latest() || estop.latched) continue;
      const auto v = in.vector();
      world.command(i, v.data(), static_cast<std::size_t>(v.size()));
    }
  }

  void step() {
    taps.record_taps();
    take_commands();
    world.step();
    ++steps;
    watch_clamps();
    for (Input* in : component->inputs) in->tick();
    if (taps.recorder() && steps % record_every == 0) {
      if (own_format) world.record(*taps.recorder());
      else record_sensors();
    }
  }

  void publish() {
    if (!holding) {  // the sensors to a node on the clock go with its next advance (docs/time.md)
      holding = true;
      node->hold_sends([this](const std::string& to) { return clock.clocked(to); });
    }
    const auto& sensors = world.sensors();
    for (std::size_t i = 0; i < component->outputs.size(); ++i) {
      if (sensors[i].alias && component->outputs[i]->links() == 0) continue;  // nobody reads it
      if (buffer.size() < sensors[i].size) buffer.resize(sensors[i].size);
      world.sensor(i, buffer.data());
      component->outputs[i]->write(Eigen::Map<const Eigen::VectorXd>(buffer.data(), sensors[i].size));
    }
    if (outputs_channel != 0 && taps.recorder()) record_outputs();
    write_replayed(clock.now() - 1);
  }

  // The recorded ports' samples of ticks up to `until` not written yet, in order (docs/recording.md,
  // "Replaying ports"): at a publish at t those of the ticks before t, visible to readers from t on as the live
  // writer's would be; before a set's change at t those of t too, which the live writer wrote before it.
  void write_replayed(std::int64_t until) {
    const auto& ports = world.recorded_ports();
    if (ports.empty() || !component) return;
    replay_next.resize(ports.size(), 0);
    for (std::size_t i = 0; i < ports.size(); ++i) {
      const RecordedPort& p = ports[i];
      for (std::size_t& k = replay_next[i]; k < p.times.size() && p.times[k] <= until; ++k, ++replay_written)
        component->replayed[i]->write(Eigen::Map<const Eigen::VectorXd>(p.values.data() + k * p.size, p.size));
    }
  }

  Value status() const {
    Value v = clock.status();
    ValueSink sink(v);
    world.status(sink);
    if (!world.recorded_ports().empty()) sink.integer("replay_samples_written", static_cast<std::int64_t>(replay_written));
    if (!refused.empty()) {
      Value m = Value::map();
      for (const auto& [input, n] : refused) m.set(input, static_cast<std::int64_t>(n));
      v.set("writers_refused", std::move(m));
      sink.texts("second_writers", second_writers);
    }
    v.set("estop", Value::map().set("latched", estop.latched).set("t", estop.t).set("source", estop.source)
                       .set("presses", static_cast<std::int64_t>(estop.presses))
                       .set("held_samples", static_cast<std::int64_t>(estop.held)));
    if (!estop.log.empty()) sink.texts("estop_log", estop.log);
    return v;
  }

  // The event `second_writer {input, writer, holder, now}` (docs/safety.md) to every supervisor on the clock:
  // the one that owns the refused writer's leaf says it.
  void tell_second_writer(const std::string& input, const std::string& writer, const std::string& holder) {
    const Message ev{"second_writer", 0, Value::map()
                                             .set("input", "world." + input)
                                             .set("writer", writer)
                                             .set("holder", holder)
                                             .set("now", static_cast<std::int64_t>(clock.now()))};
    std::erase_if(supervisors, [](const std::weak_ptr<Channel>& w) { return w.expired(); });
    for (const auto& w : supervisors)
      if (auto c = w.lock(); c && c->is_open()) c->send(ev);
  }

  // estop {source}: pressed now, answers {t, latched, already, source}; release {what = "estop", source}:
  // answers {t}, or an error; estop_watch {}: this channel is told each press and release (event estop
  // {latched, t, source}), answers the state now.
  bool handle_estop(const std::shared_ptr<Channel>& ch, const Message& m) {
    const std::string source = m.payload["source"].as_string();
    if (m.type == "estop") {
      const bool already = !press(source);
      return ch->reply(m, Value::map().set("t", estop.t).set("latched", true).set("already", already)
                              .set("source", estop.source)), true;
    }
    if (m.type == "release") {
      if (m.payload["what"].as_string() != kEstopInput)
        return ch->reply_error(m, "release: name what to release: release {what = \"estop\"}"), true;
      const std::string error = release(source);
      if (!error.empty()) return ch->reply_error(m, "release: " + error), true;
      return ch->reply(m, Value::map().set("t", estop.t)), true;
    }
    if (m.type != "estop_watch") return false;
    const bool known = std::any_of(estop.watchers.begin(), estop.watchers.end(),
                                   [&](const std::weak_ptr<Channel>& w) { return w.lock() == ch; });
    if (!known) estop.watchers.push_back(ch);  // once per channel
    return ch->reply(m, Value::map().set("latched", estop.latched).set("t", estop.t).set("source", estop.source)), true;
  }

  bool handle(const std::shared_ptr<Channel>& ch, const Message& m) {
    if (m.type == "clock" && m.payload["role"].as_string() == "supervisor") supervisors.push_back(ch);
    if (m.type == "status") return ch->reply(m, status()), true;
    if (m.type == "robot_description") return ch->reply(m, description()), true;
    if (handle_estop(ch, m)) return true;
    if (taps.handle(ch, m, world.time())) return true;  // tap, record_end, note
    return clock.handle(ch, m);
  }
};

DeviceNode::DeviceNode(Loop& loop, DeviceWorld& world, DeviceNodeOptions options)
    : impl_(std::make_unique<Impl>(loop, world, std::move(options))) {
  impl_->clock.on_duration = [this] {
    if (on_duration) on_duration();
  };
  // the run that drove time is gone: nobody will stop us, so stop
  impl_->clock.on_master_lost = [this](const std::string& why) {
    std::fprintf(stderr, "dca sim: %s: the world stops\n", why.c_str());
    impl_->loop.stop();
  };
  // a command lost on its way: the run cannot go on as written, and holding time would leave it waiting for
  // ever; its runner hears of the world's exit (dca.clients.world on_lost, with this line)
  impl_->clock.on_stuck = [this](const std::string& why) {
    std::fprintf(stderr, "dca sim: %s: the world stops\n", why.c_str());
    impl_->stuck = why;
    impl_->loop.stop();
  };
}

const std::string& DeviceNode::stuck() const { return impl_->stuck; }

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
        impl_->exclusive_inputs();
        impl_->taps.attach(&c->taps);
        return std::unique_ptr<Component>(std::move(c));
      });
  node->on_request([this](const std::shared_ptr<Channel>& ch, const Message& m) { return impl_->handle(ch, m); });
  // a set's change at t: the replayed samples of t first, written before it as the live writer's were
  node->before_request([this](const Message& m) {
    if (m.type == "activate" || m.type == "deactivate") impl_->write_replayed(impl_->clock.now());
  });
  impl_->node = node.get();
  return node;
}

}  // namespace dca::sim
