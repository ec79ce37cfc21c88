#include "worlds/replay/replay_world.h"

#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <stdexcept>

#include "host/codec/frames.h"
#include "host/codec/json.h"
#include "host/codec/mcap.h"

namespace dca::sim {
namespace {

std::string slurp(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw std::invalid_argument(path + ": cannot read the recording");
  f.seekg(0, std::ios::end);
  const auto size = f.tellg();
  if (size < 0 || size > (std::streamoff{1} << 30)) throw std::invalid_argument(path + ": not a file of at most 1 GiB");
  f.seekg(0);
  std::string bytes(static_cast<std::size_t>(size), '\0');
  f.read(bytes.data(), size);
  if (!f) throw std::invalid_argument(path + ": cannot read the recording");
  return bytes;
}

std::vector<DeviceSignal> signals_of(const wire::Value& list, const std::string& path) {
  std::vector<DeviceSignal> out;
  for (const auto& s : list.as_array()) {
    const auto size = s["size"].as_int(0);
    if (!s["name"].is_string() || size < 1 || size > 4096)
      throw std::invalid_argument(path + ": /dca/world/signals: a signal without a name or a size in 1-4096");
    out.push_back({s["name"].as_string(), static_cast<std::uint32_t>(size), s["units"].as_string()});
  }
  return out;
}

// /dca/world/signals's message into `rec`.
void read_signals(const std::string& data, const std::string& path, ReplayRecording* rec) {
  wire::Value v;
  std::string error;
  if (!json::decode(data, &v, &error)) throw std::invalid_argument(path + ": /dca/world/signals: " + error);
  rec->period = v["period"].as_float(0);
  if (!(rec->period > 0 && rec->period <= 0.01))
    throw std::invalid_argument(path + ": /dca/world/signals: no period in (0, 0.01] s");
  rec->sensors = signals_of(v["sensors"], path);
  rec->commands = signals_of(v["commands"], path);
}

// One /dca/world/outputs message into `rec`: false when it does not fit the signals.
bool read_outputs(const mcap::Contents::Message& m, std::size_t width, ReplayRecording* rec) {
  wire::Value v;
  if (!json::decode(m.data, &v, nullptr)) return false;
  std::vector<double> flat;
  flat.reserve(width);
  for (const auto& signal : v["values"].as_array())
    for (const auto& x : signal.as_array())
      flat.push_back(x.is_nil() ? std::numeric_limits<double>::quiet_NaN() : x.as_float());
  if (flat.size() != width) return false;
  if (!rec->times.empty() && static_cast<std::int64_t>(m.log_time) < rec->times.back()) return false;
  rec->times.push_back(static_cast<std::int64_t>(m.log_time));
  rec->values.push_back(std::move(flat));
  return true;
}

// The output path a port channel's topic names ("/main/door/hit/Out" gives "main.door.hit.Out"); "" for the
// world's own channels and the run's lines.
std::string port_of(const std::string& topic) {
  if (topic.size() < 2 || topic[0] != '/') return "";
  for (const char* own : {"/world/", "/dca/", "/robot_description"})
    if (topic.rfind(own, 0) == 0) return "";
  std::string path = topic.substr(1);
  for (char& c : path)
    if (c == '/') c = '.';
  return path;
}

// A port's sample {"value": x | [x, ...]} appended to `port` at `t`: false when it holds no numbers or not as
// many as the earlier ones (a Value port, a dynamic vector): such a port is not replayable.
bool read_sample(const std::string& data, std::int64_t t, RecordedPort* port) {
  wire::Value v;
  if (!json::decode(data, &v, nullptr) || !v.is_map()) return false;
  const wire::Value& x = v["value"];
  const auto number = [](const wire::Value& e, double* out) {
    if (e.is_nil()) return *out = std::numeric_limits<double>::quiet_NaN(), true;
    return e.is_number() ? (*out = e.as_float(), true) : false;
  };
  const std::size_t before = port->values.size();
  double d = 0;
  if (x.is_array()) {
    for (const auto& e : x.as_array()) {
      if (!number(e, &d)) return port->values.resize(before), false;
      port->values.push_back(d);
    }
  } else if (number(x, &d)) {
    port->values.push_back(d);
  } else {
    return false;
  }
  const std::size_t n = port->values.size() - before;
  if (port->times.empty()) port->size = static_cast<std::uint32_t>(n);
  if (n == 0 || n != port->size || (!port->times.empty() && t < port->times.back()))
    return port->values.resize(before), false;
  port->times.push_back(t);
  return true;
}

// Every recorded controller output with numbers of one size into rec->ports (the others are left out).
void read_ports(const mcap::Contents& c, ReplayRecording* rec) {
  std::map<std::uint16_t, RecordedPort> ports;
  std::set<std::uint16_t> broken;
  for (const auto& [id, ch] : c.channels)
    if (const std::string path = port_of(ch.topic); !path.empty()) ports[id].path = path;
  for (const auto& m : c.messages) {
    auto it = ports.find(m.channel);
    if (it == ports.end() || broken.count(m.channel)) continue;
    if (!read_sample(m.data, static_cast<std::int64_t>(m.log_time), &it->second)) broken.insert(m.channel);
  }
  for (auto& [id, p] : ports)
    if (!broken.count(id) && !p.times.empty()) rec->ports.push_back(std::move(p));
}

// A URDF world's frames (each transform's parent and child in /world/links/frames' first message) and URDF text
// (/robot_description's {"data"}) into `rec`; nothing of a message that does not hold them.
void read_robot(const mcap::Contents& c, ReplayRecording* rec) {
  std::uint16_t frames_channel = 0, description = 0;
  for (const auto& [id, ch] : c.channels) {
    if (ch.topic == "/world/links/frames") frames_channel = id;
    if (ch.topic == frames::kDescriptionTopic) description = id;
  }
  bool have_frames = false, have_description = false;
  for (const auto& m : c.messages) {
    wire::Value v;
    if (m.channel == frames_channel && !have_frames && json::decode(m.data, &v, nullptr)) {
      have_frames = true;
      for (const auto& t : v["transforms"].as_array())
        if (t["parent_frame_id"].is_string() && t["child_frame_id"].is_string())
          rec->frames.push_back({t["parent_frame_id"].as_string(), t["child_frame_id"].as_string()});
    } else if (m.channel == description && !have_description && json::decode(m.data, &v, nullptr)) {
      have_description = true;
      if (v["data"].is_string()) rec->robot_description = v["data"].as_string();
    }
  }
}

}  // namespace

std::string replay_file(const std::string& spec) {
  const std::string prefix = "replay:";
  return spec.compare(0, prefix.size(), prefix) == 0 ? spec.substr(prefix.size()) : "";
}

ReplayRecording read_replay(const std::string& path) {
  const std::string bytes = slurp(path);
  mcap::Contents c;
  std::string error;
  if (!mcap::read(bytes, &c, &error)) throw std::invalid_argument(path + ": " + error);
  std::uint16_t signals = 0, outputs = 0;
  for (const auto& [id, ch] : c.channels) {
    if (ch.topic == "/dca/world/signals") signals = id;
    if (ch.topic == "/dca/world/outputs") outputs = id;
  }
  if (signals == 0 || outputs == 0)
    throw std::invalid_argument(path + ": no world outputs to replay (record with --record-ports)");
  ReplayRecording rec;
  std::size_t width = 0;
  for (const auto& m : c.messages) {
    if (m.channel == signals && width == 0) {
      read_signals(m.data, path, &rec);
      for (const auto& s : rec.sensors) width += s.size;
    } else if (m.channel == outputs && (width == 0 || !read_outputs(m, width, &rec))) {
      throw std::invalid_argument(path + ": /dca/world/outputs: a message at " + std::to_string(m.log_time) +
                                  " ns does not fit the world's signals");
    }
  }
  read_ports(c, &rec);
  read_robot(c, &rec);
  return rec;
}

ReplayWorld::ReplayWorld(std::string path, ReplayRecording rec) : path_(std::move(path)), rec_(std::move(rec)) {
  std::size_t width = 0;
  for (const auto& s : rec_.sensors) offsets_.push_back(width), width += s.size;
  now_.assign(width, 0.0);
  catch_up();
}

void ReplayWorld::catch_up() {
  const auto period_ns = static_cast<std::int64_t>(std::llround(rec_.period * 1e9));
  const std::int64_t now = steps_ * period_ns + period_ns / 2;
  while (next_ < rec_.times.size() && rec_.times[next_] <= now) now_ = rec_.values[next_++];
}

void ReplayWorld::step() {
  ++steps_;
  catch_up();
}

void ReplayWorld::sensor(std::size_t i, double* out) const {
  for (std::uint32_t k = 0; k < rec_.sensors[i].size; ++k) out[k] = now_[offsets_[i] + k];
}

void ReplayWorld::status(StatusSink& sink) const {
  sink.integer("replayed", static_cast<std::int64_t>(next_));
  sink.integer("recorded", static_cast<std::int64_t>(rec_.times.size()));
}

std::string ReplayWorld::describe() const {
  return "replay of " + path_ + " (" + std::to_string(rec_.times.size()) + " publishes of " +
         std::to_string(rec_.sensors.size()) + " signals)";
}

std::vector<std::string> ReplayWorld::summary() const {
  return {"replayed " + std::to_string(next_) + " of " + std::to_string(rec_.times.size()) +
          " recorded publishes of the world's outputs from " + path_};
}

}  // namespace dca::sim
