#pragma once
// host/web: HTTP/WebSocket, the only users of Beast. Included only by host/web, its bindings and taps.
// Live samples for viewers (the web monitor, a Foxglove client): named topics of numbered fields, and the
// samples published on them as they flow. Pure, no I/O, one thread (the loop's): whoever gets samples (a tap on a
// port, the world's signals) publishes them here; whoever shows them (host/web's connections, a Foxglove
// protocol handler) observes the hub and decides what to send (decimation is the observer's business).
//
//   SampleHub hub;
//   auto id = hub.add_topic("main.door.hit.Force", {"fx", "fy", "fz"});
//   hub.publish(id, t_ns, values);          // every observer's on_sample, in the order they were added
//   hub.remove_topic(id);                   // on_topic_removed
//   auto ev = hub.add_stream_topic("/dca/events", "dca/events", schema);
//   hub.publish_message(ev, t_ns, json);     // every observer's on_message_sample
//   hub.history(id)                          // topic id's samples from its first, bounded and decimated
//
// History: the hub keeps every numeric topic's samples from its first in a SampleHistory
// (host/web/sample_history.h: at most history_buckets() buckets, two rows each, extremes kept), so a viewer that
// picks a topic late, or after the run's end, gets it from the start (the monitor's {"type":"history"}).
// keep_history(0) keeps none. Made again with other fields, a topic's history starts again.
#include <cstdint>
#include <map>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "host/codec/frames.h"
#include "host/web/sample_history.h"

namespace dca {

class SampleHub {
 public:
  /// A stream of samples: a name ("main.door.hit.Force", "/world/door"), its fields (one name per value).
  struct Topic {
    std::uint32_t id = 0;
    std::string name;
    std::vector<std::string> fields;
    /// Its values' units as its port's manifest writes them ("m/s, m/s, rad/s"; "" unknown): a Foxglove schema's
    /// description of each number, as a recording's (tap::json_schema).
    std::string units;
    std::uint64_t samples = 0;  ///< published so far
    /// Link frames (set_frames): each sample is a frames vector, 7 numbers per frame (host/codec/frames.h).
    std::vector<frames::Frame> frames;
    /// A topic of one message rather than samples (add_message_topic): the JSON message, its schema's name and
    /// JSON Schema. Observers send it to each new subscriber.
    std::string message, schema_name, schema;
    /// A stream of JSON messages (add_stream_topic): its schema above, its messages published one by one.
    bool stream = false;
  };
  /// Told of topics and samples. Called on the hub's thread, from inside add_topic/publish/remove_topic.
  class Observer {
   public:
    virtual ~Observer() = default;
    virtual void on_topic(const Topic&) {}
    virtual void on_topic_removed(std::uint32_t /*id*/) {}
    /// One sample: `t_ns` its time (simulated or wall, ns), `values` one per field (fewer or more are allowed:
    /// a port whose size changes).
    virtual void on_sample(const Topic& topic, std::int64_t t_ns, std::span<const double> values) = 0;
    /// One message of a stream topic (publish_message): `json` one JSON object.
    virtual void on_message_sample(const Topic& /*topic*/, std::int64_t /*t_ns*/, std::string_view /*json*/) {}
  };

  /// A new topic (or the one of that name, its fields replaced). Returns its id (1, 2, ...), stable per name.
  std::uint32_t add_topic(const std::string& name, std::vector<std::string> fields, std::string units = "");
  /// Makes topic `id` one of link frames (observers are told again, as of a new topic). False for an unknown id.
  bool set_frames(std::uint32_t id, std::vector<frames::Frame> frames);
  /// A topic of one fixed JSON message (e.g. the URDF on /robot_description, schema std_msgs/String).
  std::uint32_t add_message_topic(const std::string& name, std::string schema_name, std::string schema,
                                  std::string message, bool stream = false);
  /// A topic of JSON messages published one by one (e.g. /dca/events, the run's lines), its schema's name and JSON
  /// Schema.
  std::uint32_t add_stream_topic(const std::string& name, std::string schema_name, std::string schema);
  /// Publishes one message of a stream topic; false for an unknown topic or one that is no stream.
  bool publish_message(std::uint32_t id, std::int64_t t_ns, std::string_view json);
  /// Removes a topic (no effect on an unknown id).
  void remove_topic(std::uint32_t id);
  /// Publishes a sample; false for an unknown topic.
  bool publish(std::uint32_t id, std::int64_t t_ns, std::span<const double> values);
  /// Topic `id`'s history (nullptr: no sample yet, or none kept).
  const SampleHistory* history(std::uint32_t id) const;
  /// The buckets of each topic's history from now on (0: none kept; the default 500: at most 1,000 rows a topic).
  void keep_history(std::size_t buckets) { history_buckets_ = buckets; }
  std::size_t history_buckets() const { return history_buckets_; }
  /// The topic `id`, or nullptr.
  const Topic* topic(std::uint32_t id) const;
  /// The topic named `name`, or nullptr.
  const Topic* find(const std::string& name) const;
  const std::map<std::uint32_t, Topic>& topics() const { return topics_; }

  /// Adds an observer (not owned; remove it before it dies). It is told of no existing topic: read topics().
  void add_observer(Observer* o);
  void remove_observer(Observer* o);

 private:
  std::map<std::uint32_t, Topic> topics_;
  std::map<std::string, std::uint32_t> by_name_;
  std::map<std::uint32_t, SampleHistory> histories_;
  std::size_t history_buckets_ = 500;
  std::vector<Observer*> observers_;
  std::uint32_t next_id_ = 1;
};

}  // namespace dca
