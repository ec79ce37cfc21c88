#include "sim/world_taps.h"

#include <algorithm>
#include <cstdio>

#include "host/codec/msgs.h"
#include "host/net/channel.h"

namespace dca::sim {

using wire::Message;
using wire::Value;

WorldTaps::~WorldTaps() {
  if (!recorder_) return;
  std::string error;
  if (!recorder_->close(&error)) std::fprintf(stderr, "dca sim: %s\n", error.c_str());
  else std::printf("dca sim: recorded %s\n", recorder_->summary().c_str());
}

void WorldTaps::record_taps() {
  if (!taps_ || taps_->all().empty()) return;
  taps_->drain([this](tap::Taps::Tap& t, std::int64_t at, Bytes sample) {
    if (!recorder_) return;
    if (cdr(t))
      recorder_->write(channels_[&t], at, std::string(reinterpret_cast<const char*>(sample.data()), sample.size()));
    else recorder_->write(channels_[&t], at, tap::sample_json(t.spec, sample));
  });
  std::uint64_t dropped = 0;
  for (const auto& t : taps_->all()) dropped += t->dropped() + t->malformed;
  if (recorder_) recorder_->set_dropped(dropped);
}

bool WorldTaps::handle(const std::shared_ptr<Channel>& ch, const Message& m, double now_s) {
  if (m.type == "tap") return add_tap(ch, m), true;
  if (m.type == "record_end") return end(ch, m), true;
  if (m.type == "blackbox") {  // on demand: the black box's trigger now
    const std::string why = m.payload["why"].as_string();
    if (recorder_) recorder_->trigger(now_s, why.empty() ? "on demand" : why);
    return ch->reply(m, Value::map().set("t", now_s)), true;
  }
  if (m.type != "note") return false;
  const double t = m.payload["t"].as_float(now_s);
  const std::string& state = m.payload["state"].as_string();
  // a fault: the black box's trigger (`fault`: a crash or an escalation, dca.launch.sim's M.fault)
  if (recorder_ && (state == "aborted" || state == "lost" || m.payload["fault"].as_bool()))
    recorder_->trigger(t, m.payload["line"].as_string());
  if (recorder_ && m.payload["channel"].as_string() == "log")  // a process's stderr line (/dca/log)
    recorder_->log(t, m.payload["path"].as_string(), m.payload["line"].as_string());
  else if (recorder_)
    recorder_->note(t, m.payload["line"].as_string(), m.payload["path"].as_string(), m.payload["state"].as_string());
  ch->reply(m, Value::map());
  return true;
}

bool WorldTaps::cdr(const tap::Taps::Tap& t) const {
  return recorder_ && recorder_->profile() == "ros2" && t.spec.type == PortType::Message &&
         msgs::find_type(t.spec.message) != nullptr;
}

void WorldTaps::add_tap(const std::shared_ptr<Channel>& ch, const Message& m) {
  const auto& p = m.payload;
  if (!taps_) return void(ch->reply_error(m, "tap: the world component is not made yet"));
  const auto type = port_type_from(p["port_type"].as_string());
  if (!type) return void(ch->reply_error(m, "tap: unknown port type '" + p["port_type"].as_string() + "'"));
  PortSpec spec{p["path"].as_string(), *type, static_cast<std::uint32_t>(p["size"].as_int(1)), p["units"].as_string(), {}};
  if (spec.type == PortType::Scalar) spec.size = 1;
  spec.message = p["message"].as_string();
  const auto queue = static_cast<std::size_t>(std::clamp<std::int64_t>(p["queue"].as_int(256), 1, 4096));
  std::string error;
  const auto* t = taps_->add(spec.name, spec, queue, &error);
  if (!t) return void(ch->reply_error(m, error));
  if (recorder_ && !channels_.count(t)) {
    const std::string topic = tap::topic_of(t->path);
    const auto* msg = cdr(*t) ? msgs::find_type(t->spec.message) : nullptr;
    channels_[t] = msg ? recorder_->add_cdr_channel(topic, std::string(msg->ros_name), msg->ros2msg())
                        : recorder_->add_channel(topic, tap::json_schema(topic, t->spec));
  }
  ch->reply(m, Value::map().set("input", t->input->name()));
}

void WorldTaps::end(const std::shared_ptr<Channel>& ch, const Message& m) {
  if (!recorder_) return void(ch->reply(m, Value::map()));
  // what was written at the last tick (time held after the run's end) counted in, at its ticks
  if (const auto late = clock_.take_owner(); !late.empty()) std::fprintf(stderr, "dca sim: %s\n", late.c_str());
  record_taps();
  std::string error;
  if (!recorder_->close(&error)) return void(ch->reply_error(m, error));
  const std::string summary = recorder_->summary();
  std::printf("dca sim: recorded %s\n", summary.c_str());
  recorder_.reset();
  ch->reply(m, Value::map().set("summary", summary));
}

}  // namespace dca::sim
