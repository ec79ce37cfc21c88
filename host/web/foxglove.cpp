#include "host/web/foxglove.h"

#include <algorithm>

#include <cstring>

#include "host/codec/frames.h"
#include "host/codec/json.h"

namespace dca::foxglove {

using wire::Value;

namespace {

// A topic's fields grouped: "x[0]", "x[1]" -> one array "x" of 2; "door_angle" -> one number.
struct Field {
  std::string name;
  bool array = false;
  std::size_t count = 1;
};

std::vector<Field> layout(const SampleHub::Topic& t) {
  std::vector<Field> out;
  if (t.fields.empty()) return {{"value", true, 0}};  // every value, as one array
  for (const auto& f : t.fields) {
    const auto open = f.find('[');
    const bool indexed = open != std::string::npos && open > 0 && f.back() == ']';
    const std::string base = indexed ? f.substr(0, open) : f;
    if (indexed && !out.empty() && out.back().array && out.back().name == base) {
      ++out.back().count;
      continue;
    }
    out.push_back({base, indexed, 1});
  }
  return out;
}

}  // namespace

// (a topic's name without its leading '/', as a recording names its channel's schema: sim/recorder.h add_channel)
std::string schema_name_of(const SampleHub::Topic& topic) {
  if (!topic.schema_name.empty()) return topic.schema_name;
  if (!topic.frames.empty()) return frames::kSchemaName;
  return topic.name.size() > 1 && topic.name[0] == '/' ? topic.name.substr(1) : topic.name;
}

std::string schema_of(const SampleHub::Topic& topic) {
  if (!topic.schema.empty()) return topic.schema;
  if (!topic.frames.empty()) return frames::json_schema();
  std::string s = "{\"type\":\"object\",\"title\":";
  json::append_string(s, topic.name);
  s += ",\"properties\":{";
  // a number, described by the units when known (as a port's recorded channel: tap::json_schema)
  std::string num = "{\"type\":\"number\"";
  if (!topic.units.empty()) {
    num += ",\"description\":";
    json::append_string(num, topic.units);
  }
  num += '}';
  bool first = true;
  for (const auto& f : layout(topic)) {
    if (!first) s += ',';
    first = false;
    json::append_string(s, f.name);
    if (!f.array) {
      s += ':' + num;
    } else {
      s += ":{\"type\":\"array\",\"items\":" + num;
      if (f.count) s += ",\"minItems\":" + std::to_string(f.count) + ",\"maxItems\":" + std::to_string(f.count);
      s += '}';
    }
  }
  return s + "}}";
}

std::string message_of(const SampleHub::Topic& topic, std::int64_t t_ns, std::span<const double> values) {
  if (!topic.frames.empty()) return frames::message(topic.frames, t_ns, values.data(), values.size());
  std::string s = "{";
  std::size_t k = 0;
  bool first = true;
  for (const auto& f : layout(topic)) {
    if (k >= values.size()) break;
    if (!first) s += ',';
    first = false;
    json::append_string(s, f.name);
    s += ':';
    if (!f.array) {
      json::append_number(s, values[k++]);
      continue;
    }
    const std::size_t n = f.count ? f.count : values.size() - k;
    s += '[';
    for (std::size_t i = 0; i < n && k < values.size(); ++i, ++k) {
      if (i) s += ',';
      json::append_number(s, values[k]);
    }
    s += ']';
  }
  return s + "}";
}

Protocol::Protocol(const std::shared_ptr<web::Server>& server, std::string name) : server_(server), name_(std::move(name)) {
  server->samples().add_observer(this);
}

Protocol::~Protocol() {
  if (auto s = server_.lock()) s->samples().remove_observer(this);
}

void Protocol::on_open(const web::Connection::Ptr& c) {
  Client& cl = clients_[c->id()];
  cl.conn = c;
  Value capabilities = Value::array();
  if (get_parameters && set_parameters) capabilities.array_ref().push_back(Value("parameters"));
  if (sim_time) capabilities.array_ref().push_back(Value("time"));
  if (has_graph_) capabilities.array_ref().push_back(Value("connectionGraph"));
  const Value info = Value::map()
                         .set("op", "serverInfo")
                         .set("name", name_)
                         .set("capabilities", std::move(capabilities))
                         .set("sessionId", web::random_token(8));
  c->send(json::encode(info));
  std::vector<const SampleHub::Topic*> all;
  if (auto s = server_.lock())
    for (const auto& [id, t] : s->samples().topics()) all.push_back(&t);
  advertise(cl, all);
  if (sim_time && time_ns_ >= 0) send_time(cl, time_ns_);
}

void Protocol::advertise(Client& c, const std::vector<const SampleHub::Topic*>& topics) {
  Value channels = Value::array();
  for (const auto* t : topics)
    channels.array_ref().push_back(Value::map()
                                       .set("id", static_cast<std::int64_t>(t->id))
                                       .set("topic", t->name)
                                       .set("encoding", "json")
                                       .set("schemaName", schema_name_of(*t))
                                       .set("schema", schema_of(*t))
                                       .set("schemaEncoding", "jsonschema"));
  c.conn->send(json::encode(Value::map().set("op", "advertise").set("channels", std::move(channels))));
}

void Protocol::status(Client& c, int level, const std::string& message) {
  c.conn->send(json::encode(Value::map().set("op", "status").set("level", level).set("message", message)));
}

void Protocol::on_message(const web::Connection::Ptr& c, std::string_view data, bool binary) {
  auto it = clients_.find(c->id());
  if (it == clients_.end()) return;
  Client& cl = it->second;
  if (binary) return status(cl, 2, "this server takes no client messages (no clientPublish)");
  Value msg;
  std::string error;
  if (!json::decode(data, &msg, &error) || !msg.is_map()) return status(cl, 2, "not a JSON object: " + error);
  const std::string op = msg["op"].as_string();
  if (op == "subscribe") return subscribe(cl, msg);
  if (op == "unsubscribe") return unsubscribe(cl, msg);
  if (op == "subscribeConnectionGraph" && has_graph_) {
    cl.graph = true;
    return send_graph(cl, {});
  }
  if (op == "unsubscribeConnectionGraph" && has_graph_) {
    cl.graph = false;
    return;
  }
  if (op == "getParameters" && get_parameters) return get_params(cl, msg);
  if (op == "setParameters" && set_parameters) return set_params(cl, msg);
  status(cl, 1, "unsupported operation '" + op + "'");
}

// The answer to a parameter request of `c`: parameterValues {parameters, id} (id as the request had it), or a
// status naming the request; nothing when the connection closed meanwhile.
Protocol::ParamsReply Protocol::answer(const Client& c, std::string op, const Value& id) {
  std::weak_ptr<web::Connection> weak = c.conn;
  return [weak, op = std::move(op), id](const Value& params, const std::string& error) {
    const auto conn = weak.lock();
    if (!conn || !conn->is_open()) return;
    if (!error.empty()) {
      const std::string said = op + (id.is_string() ? " '" + id.as_string() + "'" : "") + ": " + error;
      conn->send(json::encode(Value::map().set("op", "status").set("level", 2).set("message", said)));
      return;
    }
    Value m = Value::map().set("op", "parameterValues").set("parameters", params.is_array() ? params : Value::array());
    if (id.is_string()) m.set("id", id);
    conn->send(json::encode(m));
  };
}

// getParameters {parameterNames: [string], id}: the names (none or empty: every one) checked, then asked of the run.
void Protocol::get_params(Client& c, const Value& msg) {
  const Value& names = msg["parameterNames"];
  const Value& id = msg["id"];
  if (!(names.is_nil() || names.is_array()) || !(id.is_nil() || id.is_string()))
    return status(c, 2, "getParameters: parameterNames is an array of strings, id a string");
  std::vector<std::string> list;
  for (const auto& n : names.as_array()) {
    if (!n.is_string()) return status(c, 2, "getParameters: parameterNames is an array of strings");
    list.push_back(n.as_string());
  }
  get_parameters(list, answer(c, "getParameters", id));
}

// setParameters {parameters: [{name, value}], id}: each needs a name and a value (a key is never unset), then
// written by the run as one change.
void Protocol::set_params(Client& c, const Value& msg) {
  const Value& ps = msg["parameters"];
  const Value& id = msg["id"];
  if (!ps.is_array() || ps.as_array().empty() || !(id.is_nil() || id.is_string()))
    return status(c, 2, "setParameters: parameters is a non-empty array of {name, value}, id a string");
  Value clean = Value::array();
  for (const auto& p : ps.as_array()) {
    const Value& name = p["name"];
    const Value& value = p["value"];
    if (!name.is_string() || name.as_string().empty() || value.is_nil())
      return status(c, 2, "setParameters: each parameter needs a name and a value (a key cannot be unset)");
    clean.array_ref().push_back(Value::map().set("name", name).set("value", value));
  }
  set_parameters(clean, answer(c, "setParameters", id));
}

// A client holds at most one subscription per channel (as Foxglove's own server): a request cannot make one sample
// go out many times. Refused entries are answered with one status per request, the first reason and the count.
void Protocol::subscribe(Client& c, const Value& msg) {
  std::string first_refusal;
  std::size_t refused = 0;
  const auto refuse = [&](std::string why) {
    if (refused++ == 0) first_refusal = std::move(why);
  };
  const auto server = server_.lock();
  for (const auto& s : msg["subscriptions"].as_array()) {
    if (!s["id"].is_int() || !s["channelId"].is_int() || s["id"].as_int() < 0) {
      refuse("each subscription needs an id and a channelId");
      continue;
    }
    const auto id = static_cast<std::uint32_t>(s["id"].as_int());
    const auto channel = static_cast<std::uint32_t>(s["channelId"].as_int());
    const auto* t = server ? server->samples().topic(channel) : nullptr;
    if (c.subs.count(id)) {
      refuse("subscription id " + std::to_string(id) + " is in use");
    } else if (!t) {
      refuse("no channel " + std::to_string(channel));
    } else if (std::any_of(c.subs.begin(), c.subs.end(), [&](const auto& e) { return e.second == channel; })) {
      refuse("channel " + std::to_string(channel) + " is subscribed already");
    } else {
      const bool first = c.subs.empty();
      c.subs[id] = channel;
      count(channel, 1);
      if (first && on_watch) on_watch();
      if (!t->message.empty()) send_message(c, id, 0, t->message);  // a topic of one message: it, at once
    }
  }
  if (refused > 0)
    status(c, 2, "subscribe: " + first_refusal +
                     (refused > 1 ? " (and " + std::to_string(refused - 1) + " more refused)" : std::string()));
}

void Protocol::unsubscribe(Client& c, const Value& msg) {
  for (const auto& s : msg["subscriptionIds"].as_array()) {
    auto it = c.subs.find(static_cast<std::uint32_t>(s.as_int(-1)));
    if (it == c.subs.end()) continue;
    const auto channel = it->second;
    c.subs.erase(it);
    count(channel, -1);
  }
}

// The subscriptions of `channel` over every client: the first and the last are told.
void Protocol::count(std::uint32_t channel, int delta) {
  Subscribed& s = subscribers_[channel];
  s.n += delta;
  const auto server = server_.lock();
  const auto* t = server ? server->samples().topic(channel) : nullptr;
  if (t) s.topic = t->name;
  if (delta > 0 && s.n == 1 && t && on_first_subscribe) on_first_subscribe(t->name);
  if (s.n <= 0) {
    const std::string topic = std::move(s.topic);
    subscribers_.erase(channel);
    if (delta < 0 && !topic.empty() && on_last_unsubscribe) on_last_unsubscribe(topic);
  }
}

void Protocol::on_close(const web::Connection::Ptr& c, const std::string&) {
  auto it = clients_.find(c->id());
  if (it == clients_.end()) return;
  const auto subs = std::move(it->second.subs);
  clients_.erase(it);
  for (const auto& [id, channel] : subs) count(channel, -1);
}

void Protocol::on_topic(const SampleHub::Topic& t) {
  for (auto& [id, c] : clients_) advertise(c, {&t});
}

void Protocol::on_topic_removed(std::uint32_t id) {
  const std::string m =
      json::encode(Value::map().set("op", "unadvertise").set("channelIds", Value::Array{Value(static_cast<std::int64_t>(id))}));
  int gone = 0;
  for (auto& [cid, c] : clients_) {
    gone += static_cast<int>(std::erase_if(c.subs, [id](const auto& s) { return s.second == id; }));
    c.conn->send(m);
  }
  // Its subscriptions end with it: the last one tells on_last_unsubscribe, as an unsubscribe would (the hub has
  // already forgotten the topic; its name was kept at subscribe).
  if (gone > 0) count(id, -gone);
}

// Message Data: opcode 1, the subscription id, the timestamp (ns), the message; little-endian. Counted.
void Protocol::send_message(Client& c, std::uint32_t sub, std::int64_t t_ns, const std::string& payload) {
  std::string frame(1 + 4 + 8, '\0');
  frame[0] = 1;
  const std::uint64_t ts = t_ns < 0 ? 0 : static_cast<std::uint64_t>(t_ns);
  for (int i = 0; i < 4; ++i) frame[1 + i] = static_cast<char>((sub >> (8 * i)) & 0xff);
  for (int i = 0; i < 8; ++i) frame[5 + i] = static_cast<char>((ts >> (8 * i)) & 0xff);
  frame += payload;
  if (c.conn->send(std::move(frame), true, true)) ++sent_;
  else ++dropped_;
}

// Time (opcode 2, the timestamp in ns, little-endian); droppable as samples are.
void Protocol::send_time(Client& c, std::int64_t t_ns) {
  std::string frame(1 + 8, '\0');
  frame[0] = 2;
  const auto ts = static_cast<std::uint64_t>(t_ns < 0 ? 0 : t_ns);
  for (int i = 0; i < 8; ++i) frame[1 + i] = static_cast<char>((ts >> (8 * i)) & 0xff);
  c.conn->send(std::move(frame), true, true);
}

// The run's time reached t_ns: Time to every client once it advanced 10 ms past the last one sent (or `force`:
// the world's own time), never backwards.
void Protocol::advance(std::int64_t t_ns, bool force) {
  if (!sim_time || time_ended_ || t_ns <= time_ns_) return;
  time_ns_ = t_ns;
  constexpr std::int64_t kStep = 10'000'000;
  if (!force && time_sent_ns_ >= 0 && t_ns - time_sent_ns_ < kStep) return;
  time_sent_ns_ = t_ns;
  for (auto& [cid, c] : clients_) send_time(c, t_ns);
}

void Protocol::time(std::int64_t t_ns) { advance(t_ns, true); }

void Protocol::end_time(std::int64_t t_ns) {
  advance(t_ns, true);
  time_ended_ = true;
}

namespace {
Value graph_entries(const std::vector<std::pair<std::string, std::vector<std::string>>>& g, const char* ids_key) {
  Value out = Value::array();
  for (const auto& [name, ids] : g) {
    Value list = Value::array();
    for (const auto& id : ids) list.array_ref().push_back(Value(id));
    out.array_ref().push_back(Value::map().set("name", name).set(ids_key, std::move(list)));
  }
  return out;
}
}  // namespace

// connectionGraphUpdate: the whole graph (publishers and subscribers of each topic), and the topics gone since.
void Protocol::send_graph(Client& c, const std::vector<std::string>& removed) {
  Value gone = Value::array();
  for (const auto& r : removed) gone.array_ref().push_back(Value(r));
  c.conn->send(json::encode(Value::map()
                                .set("op", "connectionGraphUpdate")
                                .set("publishedTopics", graph_entries(published_, "publisherIds"))
                                .set("subscribedTopics", graph_entries(subscribed_, "subscriberIds"))
                                .set("advertisedServices", Value::array())
                                .set("removedTopics", std::move(gone))
                                .set("removedServices", Value::array())));
}

void Protocol::set_graph(Graph published, Graph subscribed) {
  std::vector<std::string> removed;
  for (const auto* old : {&published_, &subscribed_})
    for (const auto& [name, ids] : *old) {
      const auto has = [&n = name](const Graph& g) {
        return std::any_of(g.begin(), g.end(), [&](const auto& e) { return e.first == n; });
      };
      if (!has(published) && !has(subscribed) && std::find(removed.begin(), removed.end(), name) == removed.end())
        removed.push_back(name);
    }
  published_ = std::move(published);
  subscribed_ = std::move(subscribed);
  has_graph_ = true;
  for (auto& [cid, c] : clients_)
    if (c.graph) send_graph(c, removed);
}

void Protocol::on_message_sample(const SampleHub::Topic& t, std::int64_t t_ns, std::string_view json) {
  advance(t_ns, false);
  if (!subscribers_.count(t.id)) return;
  const std::string payload(json);
  for (auto& [cid, c] : clients_)
    for (const auto& [sub, channel] : c.subs)
      if (channel == t.id) send_message(c, sub, t_ns, payload);
}

void Protocol::on_sample(const SampleHub::Topic& t, std::int64_t t_ns, std::span<const double> values) {
  advance(t_ns, false);
  if (!subscribers_.count(t.id)) return;
  std::string payload;
  for (auto& [cid, c] : clients_) {
    for (const auto& [sub, channel] : c.subs) {
      if (channel != t.id) continue;
      if (payload.empty()) payload = message_of(t, t_ns, values);
      send_message(c, sub, t_ns, payload);
    }
  }
}

}  // namespace dca::foxglove
