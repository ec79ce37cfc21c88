#pragma once
// host/web: HTTP/WebSocket, the only users of Beast. Included only by host/web, its bindings and taps.
// The Foxglove WebSocket protocol (`foxglove.websocket.v1`, github.com/foxglove/ws-protocol docs/spec.md) on the
// monitor's server (host/web): Foxglove, Lichtblick and any ws-protocol client connect to a running system on the
// same port as the monitor's page (the subprotocol chooses), with the same token (`?token=T` in the URL), and
// plot its ports and the world's signals live.
//
// Channels are the topics of the server's SampleHub (host/web/sample_hub.h): the ports tapped live (host/net/tap.h,
// "/main/door/hit/Force") and whatever else publishes there ("/world/door"). Each is advertised with encoding
// "json" and a JSON Schema (schemaEncoding "jsonschema") made from the topic's fields: fields named "x[0]",
// "x[1]", ... form one array "x"; a topic without fields has one array "value". A message is one sample as such
// a JSON object, its timestamp the sample's time (simulated time in simulated runs), the same objects and topics
// as the MCAP recordings (`--record-ports`), so one layout serves both. A topic of link frames (a URDF world's
// /world/links/frames) is advertised as foxglove.FrameTransforms, each sample one such message; a topic of one
// message (/robot_description, std_msgs/String) sends it to each subscriber when it subscribes: so Foxglove's
// 3D panel draws the robot (host/codec/frames.h).
//
// Server -> client: serverInfo (at open; the capability `parameters` when the run serves them, below), advertise
// (at open: every topic; later: each new one), unadvertise (a topic removed), status (a refused request), binary
// Message Data (opcode 1, subscription id, timestamp in ns, the JSON payload; little-endian), parameterValues
// {parameters: [{name, value}], id} (the answer to getParameters and setParameters). Client -> server: subscribe
// {subscriptions: [{id, channelId}]}, unsubscribe {subscriptionIds}, getParameters {parameterNames, id} (none:
// every one), setParameters {parameters: [{name, value}], id}. Anything else is answered with a status (level 1
// or 2) and ignored; a malformed message too; the connection stays.
//
// Parameters are the run's configuration repository's keys (docs/configuration.md): the Protocol only parses and
// answers; get_parameters and set_parameters (set by the run: dca.launch.live) read and write them. A set goes the
// way of the monitor's config_set, so it reaches the running leaves whose live parameter reads that key. Samples are sent droppable
// (host/web: a slow client loses samples, counted, and never stalls the loop).
//
// When a channel gets its first subscriber (over every connection) on_first_subscribe(topic) runs, and when its
// last one goes on_last_unsubscribe(topic): the run makes its tap then (a tap costs nothing until someone looks).
//
// In simulated time (sim_time set before a client connects) serverInfo says `time`, and the server sends Time
// (binary, opcode 2, the timestamp in ns) as the run's time advances: from time(t_ns) (the world's time, told by the
// run) and from the samples' timestamps, at most one per 10 ms of simulated time, never backwards; so Foxglove and
// Lichtblick plot on the simulated clock. A topic of JSON messages (SampleHub::add_stream_topic: the run's lines on
// /dca/events, as the recordings have them) sends each message to its subscribers. With a connection graph
// (set_graph: each topic's publishers and subscribers, the leaves' paths) serverInfo says `connectionGraph`; a
// client that sends subscribeConnectionGraph gets connectionGraphUpdate at once and on every change, until
// unsubscribeConnectionGraph. on_watch runs when a client subscribes to its first channel (a viewer watching:
// dca run --monitor-wait starts time then; a client that only reads or writes parameters does not).
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "host/codec/wire.h"
#include "host/web/sample_hub.h"
#include "host/web/web.h"

namespace dca::foxglove {

/// The subprotocol's name.
inline constexpr const char* kSubprotocol = "foxglove.websocket.v1";

/// The schema name of a topic: its own (a message topic's), foxglove.FrameTransforms (link frames), else its name.
std::string schema_name_of(const SampleHub::Topic& topic);
/// The JSON Schema of a topic's messages (see the header).
std::string schema_of(const SampleHub::Topic& topic);
/// One sample of `topic` at `t_ns` as its JSON message (non-finite numbers as null); link frames as one
/// foxglove.FrameTransforms.
std::string message_of(const SampleHub::Topic& topic, std::int64_t t_ns, std::span<const double> values);

class Protocol final : public web::Protocol, public SampleHub::Observer {
 public:
  /// Serves the topics of `server`'s samples() as `name` (serverInfo's name); observes them while the server lives
  /// (a connection may hold the protocol longer than the server).
  Protocol(const std::shared_ptr<web::Server>& server, std::string name);
  ~Protocol() override;
  Protocol(const Protocol&) = delete;
  Protocol& operator=(const Protocol&) = delete;

  void on_open(const web::Connection::Ptr& c) override;
  void on_message(const web::Connection::Ptr& c, std::string_view data, bool binary) override;
  void on_close(const web::Connection::Ptr& c, const std::string& reason) override;

  void on_topic(const SampleHub::Topic& t) override;
  void on_topic_removed(std::uint32_t id) override;
  void on_sample(const SampleHub::Topic& t, std::int64_t t_ns, std::span<const double> values) override;
  void on_message_sample(const SampleHub::Topic& t, std::int64_t t_ns, std::string_view json) override;

  /// Simulated time: the capability `time` (set before clients connect).
  bool sim_time = false;
  /// The run's time now (simulated, ns): a Time message to every client when it advanced (see the header).
  void time(std::int64_t t_ns);
  /// The run ended at t_ns: a last Time of t_ns; what comes after (the shutdown, a world that steps on) moves the
  /// clock no further.
  void end_time(std::int64_t t_ns);
  /// The connection graph: {published = {{name, ids}...}, subscribed = {{name, ids}...}} as wire values
  /// [[topic, [id...]]...]; set before clients connect for serverInfo to say `connectionGraph`, again at any time.
  void set_graph(std::vector<std::pair<std::string, std::vector<std::string>>> published,
                 std::vector<std::pair<std::string, std::vector<std::string>>> subscribed);
  std::function<void()> on_watch;
  /// The clients connected now.
  std::size_t clients() const { return clients_.size(); }
  std::function<void(const std::string& topic)> on_first_subscribe, on_last_unsubscribe;
  /// The answer to a parameter request, once, from the loop: params = [{name, value}] (parameterValues to the
  /// connection that asked, while it is open), or error "" -> params, else why not (a status, level 2).
  using ParamsReply = std::function<void(const wire::Value& params, const std::string& error)>;
  /// getParameters: the values of `names` (empty: every one). With set_parameters, set before a client connects,
  /// serverInfo says `parameters`.
  std::function<void(const std::vector<std::string>& names, ParamsReply reply)> get_parameters;
  /// setParameters: `params` = [{name, value}] (each with a name and a value), written at once; the reply has
  /// their values after the write.
  std::function<void(const wire::Value& params, ParamsReply reply)> set_parameters;
  /// Message Data frames sent, and those the connections dropped (slow clients).
  std::uint64_t sent() const { return sent_; }
  std::uint64_t dropped() const { return dropped_; }

 private:
  struct Client {
    web::Connection::Ptr conn;
    std::map<std::uint32_t, std::uint32_t> subs;  // subscription id -> channel (topic id)
    bool graph = false;                           // subscribed to the connection graph
  };
  using Graph = std::vector<std::pair<std::string, std::vector<std::string>>>;
  void send_graph(Client& c, const std::vector<std::string>& removed);
  void send_time(Client& c, std::int64_t t_ns);
  void advance(std::int64_t t_ns, bool force);
  void advertise(Client& c, const std::vector<const SampleHub::Topic*>& topics);
  void status(Client& c, int level, const std::string& message);
  void subscribe(Client& c, const wire::Value& msg);
  void unsubscribe(Client& c, const wire::Value& msg);
  void get_params(Client& c, const wire::Value& msg);
  void set_params(Client& c, const wire::Value& msg);
  static ParamsReply answer(const Client& c, std::string op, const wire::Value& id);
  void count(std::uint32_t channel, int delta);
  void send_message(Client& c, std::uint32_t sub, std::int64_t t_ns, const std::string& payload);

  std::weak_ptr<web::Server> server_;
  std::string name_;
  std::map<std::uint64_t, Client> clients_;          // by connection id
  struct Subscribed {
    int n = 0;          // subscriptions over every client
    std::string topic;  // its name, kept for a topic the hub removes
  };
  std::map<std::uint32_t, Subscribed> subscribers_;  // by channel
  std::uint64_t sent_ = 0, dropped_ = 0;
  std::int64_t time_ns_ = -1, time_sent_ns_ = -1;
  bool time_ended_ = false;  // the run's latest time; the last one sent
  bool has_graph_ = false;
  Graph published_, subscribed_;
};

}  // namespace dca::foxglove
