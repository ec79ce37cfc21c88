#pragma once
// host/net: sockets on the io_context (Asio). Never Beast, never host/web.
// Taps (docs/recording.md): the samples of any output port of a running system, by its path
// ("main.door.hit.Force"), without changing the run.
//
// A tap is one more link of the output, made by the supervisor that reaches the port's leaf (the root reaches
// every leaf through the tree), to a tap input "tap:PATH" of a tap endpoint:
//   connect {out = PORT, to = TAP_COMPONENT, in = "tap:PATH", set = "tap:PATH", mode = "push", queue = Q,
//            stamped = true}    then    activate {set = "tap:PATH"}
// It travels like every link (in process, Unix socket or TCP, authenticated with the cluster key), and it is
// *stamped*: each sample goes with the writer's clock time before it (8 bytes, host order; Endpoint::set_clock),
// so the tap knows when it was written (its tick, in simulated time) wherever the tap is. A tap input is a Value
// input named "tap:..." (is_tap_input): it takes a stamped link from an output of any type.
//
// What a tap does not change: the output's samples, counts and digest; the run's trace (a tap's set switches are
// left out of it, host/node.cpp); in simulated time its link is counted like any other, so a tap endpoint on the
// clock (the world) takes in exactly the samples written before each tick, and one off the clock is never
// waited for. A slow tap never blocks the writer: a backed-up socket drops at the writer beyond its backlog
// (LinkInfo::tx_dropped), and a tap input keeps at most its queue, dropping the oldest (counted).
//
// Tap endpoints: the world process (`tap {path, port_type, size, units, queue}`, sim/world_node.h: lock-stepped, so a
// recording's samples are exact and at their tick) and TapPoint (an Endpoint of its own, e.g. in the root
// process, for live viewers: off the clock).
#include "host/loop.h"  // first: Asio's core, with GCC 12's false positives silenced

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "host/net/endpoint.h"
#include "host/port.h"

namespace dca::tap {

/// The tap input (and set) of the output at `path` ("main.door.hit.Force"): "tap:main.door.hit.Force".
std::string input_name(const std::string& path);
/// The topic a viewer shows the output at `path` under: "/main/door/hit/Force" (as the world's "/world/door").
std::string topic_of(const std::string& path);
/// Splits a stamped sample into its writer's time and the sample's bytes; false when it is too short.
bool unstamp(Bytes stamped, std::int64_t& t, Bytes& sample);
/// The JSON Schema of the messages of a port of spec `spec` (sample_json's), titled `title`.
std::string json_schema(const std::string& title, const PortSpec& spec);
/// A sample as a JSON object: {"value": x} (scalar), {"value": [x, ...]} (vectors), {"value": <the msgpack value
/// as JSON>} (value ports; a malformed one is null), {"value": {"linear": {"x": 1, ...}, ...}} (message ports:
/// fields by name, docs/data-plane.md "Typed messages"). Non-finite numbers are null.
std::string sample_json(const PortSpec& spec, Bytes sample);
/// A numeric sample's values (scalar and vector ports); false for value and message ports and malformed samples.
bool sample_values(const PortSpec& spec, Bytes sample, std::vector<double>& out);

/// The tap inputs of one component (a PortSet it owns): added by path, drained in order.
class Taps {
 public:
  /// One tap: the tapped output's path and spec, and its input here.
  struct Tap {
    std::string path;
    PortSpec spec;     ///< the tapped output's
    Input* input = nullptr;
    std::uint64_t taken = 0;      ///< samples drained
    std::uint64_t malformed = 0;  ///< samples without a stamp (refused, counted)
    std::uint64_t dropped() const { return input ? input->stats().dropped : 0; }
  };
  explicit Taps(PortSet& ports) : ports_(&ports) {}
  /// The tap of the output `path` with spec `spec` (the one already made when there is one): its input holds up
  /// to `queue` samples. nullptr with *error when the name is taken by another input or the spec is not one.
  Tap* add(const std::string& path, const PortSpec& spec, std::size_t queue, std::string* error);
  /// The tap of `path`, or nullptr.
  Tap* find(const std::string& path) const;
  /// Takes every queued sample, tap by tap in the order they were added, each in arrival order:
  /// sink(tap, writer's time, sample bytes).
  using Sink = std::function<void(Tap&, std::int64_t t, Bytes sample)>;
  void drain(const Sink& sink);
  const std::vector<std::unique_ptr<Tap>>& all() const { return taps_; }

 private:
  PortSet* ports_;
  std::vector<std::unique_ptr<Tap>> taps_;
};

/// A tap endpoint off the clock, for live viewers: an Endpoint and one component `name` of tap inputs. Samples
/// are drained soon after they arrive (one post per burst), so while the loop is busy a tap input keeps its
/// queue's newest and counts the dropped. Register `name` with the daemon (endpoints: location()) so that the
/// nodes' `connect` finds it.
class TapPoint {
 public:
  /// Throws std::runtime_error when it cannot listen (Endpoint::listen).
  TapPoint(boost::asio::io_context& io, const std::string& host, std::string name, EndpointOptions options,
           const std::string& uds_path, const std::string& tcp_address = "127.0.0.1:0");
  ~TapPoint();
  TapPoint(const TapPoint&) = delete;
  TapPoint& operator=(const TapPoint&) = delete;
  const std::string& name() const { return name_; }
  Location location() const { return endpoint_.location(); }
  Taps& taps() { return taps_; }
  Endpoint& endpoint() { return endpoint_; }
  /// Adds the tap of `path` (as Taps::add), its samples going to on_sample.
  Taps::Tap* add(const std::string& path, const PortSpec& spec, std::size_t queue, std::string* error);
  /// Each sample, in arrival order per tap.
  Taps::Sink on_sample;

 private:
  void schedule();
  boost::asio::io_context& io_;
  std::string name_;
  PortSet ports_;
  Taps taps_{ports_};
  Endpoint endpoint_;
  bool posted_ = false;
  std::shared_ptr<bool> alive_ = std::make_shared<bool>(true);
};

}  // namespace dca::tap
