#pragma once
// host/net: sockets on the io_context (Asio). Never Beast, never host/web.
// The data plane's I/O: one Endpoint per process moves samples between ports (host/port) over connections
// (docs/data-plane.md). A connection (a link) goes output -> input:
//   - in the same process: a direct hand-off (the sample is copied into the input's queue, no socket);
//   - on the same host: over a Unix stream socket;
//   - across hosts: over TCP with TCP_NODELAY.
// Endpoint::connect picks the transport from where the two ends live (choose_transport).
//
// Between two endpoints, one socket connection carries every link, in both directions: the first link to an
// endpoint's address opens it, later links either way ride it (the opener introduces its own addresses, so the
// acceptor's links towards the opener find it), and each data frame names its link (host/codec/data_frame.h). A
// sample's reply therefore travels on the socket its request came on, and TCP piggybacks its acknowledgement.
// A connection stays open, idle or not, until one of the endpoints goes away or it breaks; it then takes every
// link on it along, each reported `broken` at both ends. Two endpoints that open connections to each other
// at the same instant each open one: the links that have sent nothing yet then move to the one opened by the
// endpoint whose address sorts first, and the other, idle, closes. The links to one process share its
// connection's order and backlog: a backed-up connection drops the samples of every link on it (counted).
//
// Every connection belongs to a connection set (a name chosen by the supervisor) and is created inactive.
// Activating or deactivating a set flips one flag: no socket is opened or closed. An inactive connection sends
// nothing (its samples are skipped and counted). A broken connection (peer closed, reset) is reported to the
// endpoint's event callback on both sides; it never blocks a writer. A backed-up socket never blocks either:
// beyond a backlog limit its samples are dropped and counted (LinkInfo::tx_dropped).
//
// Sockets carry data frames (host/codec/data_frame) on framed sockets (host/net/framed_socket). Every socket connection
// is authenticated before anything else (docs/data-plane.md, "Security"): the opening side runs the
// control plane's challenge-response (host/net/auth.h) keyed with data_key(cluster key); the accepting
// side takes nothing else (frames over data_frame::kMaxAuthFrame before it are refused at their length prefix),
// answers a refusal with its reason and closes. A connection not authenticated and introduced by
// handshake_timeout, or holding a partial frame for partial_frame_timeout, is closed. A link's hello is checked
// (data_frame::decode_hello, then the destination's ports); a refused hello refuses that link only. An Endpoint
// without a key refuses every socket connection, both ways; in-process connections cross no socket and need none.
// Threading: everything here runs on the process's one io_context thread; nothing takes a lock.
#include "host/loop.h"  // first: Asio's core, with GCC 12's false positives silenced

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "host/net/auth.h"
#include "host/port.h"

namespace dca {

/// An event of the data plane, reported to Endpoint::on_event.
struct CommsEvent {
  enum class Kind : std::uint8_t { Broken, Overflow };
  Kind kind = Kind::Broken;
  std::string component;  ///< the local component concerned
  std::string port;       ///< its port
  std::string peer;       ///< the other end ("PATH.port" or an address)
  std::string set;        ///< the connection's set ("" when unknown)
  std::string reason;     ///< what happened
};

/// Statistics of one connection.
struct LinkInfo {
  ConnectRequest request;
  Transport transport = Transport::InProcess;
  bool active = false;
  bool broken = false;
  std::uint64_t sent = 0;     ///< samples handed to the transport (or kept back for it: Endpoint::set_hold)
  std::uint64_t skipped = 0;  ///< samples not sent while the set was inactive
  std::uint64_t tx_dropped = 0;  ///< samples dropped because the socket was backed up beyond its limit
  std::uint64_t bytes = 0;    ///< bytes of this link's frames handed to the socket (0 in-process)
};

/// The key the data plane's handshake uses, derived from the cluster key (auth::data_key).
using auth::data_key;

/// How an Endpoint authenticates and bounds its socket connections.
struct EndpointOptions {
  auth::Key key;  ///< the cluster key (host/net/auth.h); empty: every socket connection is refused, both ways
  std::chrono::milliseconds handshake_timeout{5000};     ///< from connect/accept to authenticated and introduced
  std::chrono::milliseconds partial_frame_timeout{5000};  ///< longest a partial frame may stay incomplete
};

/// One per process: the components' ports, the data listeners (Unix socket and TCP), the connections and
/// the connection sets. Runs on one io_context; not thread-safe (nothing in the data plane takes a lock).
class Endpoint {
 public:
  /// `host` is this process's logical host name (chooses Unix socket vs TCP). Without `options.key` only
  /// in-process connections work.
  Endpoint(boost::asio::io_context& io, std::string host, EndpointOptions options = {});
  ~Endpoint();
  Endpoint(const Endpoint&) = delete;
  Endpoint& operator=(const Endpoint&) = delete;

  /// Listens for data connections on a Unix socket at `path` (removed first if stale) and on TCP at
  /// `tcp_address` ("127.0.0.1:0" picks a free port). Throws std::runtime_error on failure.
  void listen(const std::string& uds_path, const std::string& tcp_address = "127.0.0.1:0");
  /// This endpoint's address, for the NameServer.
  Location location() const;
  /// The logical host name.
  const std::string& host() const { return host_; }

  /// Makes a component's ports reachable under `name` (PATH). Call remove_component before destroying the
  /// PortSet (connections also survive a port destroyed first: they stop delivering).
  void add_component(const std::string& name, PortSet& ports);
  /// Removes a component: its connections (both directions) are closed, the other ends told.
  void remove_component(const std::string& name);
  /// The component registered as `name`, or nullptr.
  PortSet* component(std::string_view name) const;

  /// Result of connect: "" on success, else the reason (names the valid ports when one is unknown).
  using ConnectDone = std::function<void(const std::string& error)>;
  /// Connects `r.from`.`r.out` (local) to `r.to`.`r.in`, local or at `dest`. Created inactive (or active at
  /// once if its set already is). `done` runs exactly once: on success, on refusal by the destination, or
  /// after `timeout_ms` without an answer. In-process connections complete before connect returns. The same
  /// connection (from, out, to, in, set) asked again is the one already made, unless it broke or `dest` is now
  /// at another address (a restarted process): then it replaces the old link.
  void connect(const ConnectRequest& r, const Location& dest, ConnectDone done, int timeout_ms = 5000);
  /// Removes every connection of set `set` from this endpoint's outputs (the destinations are told; the socket
  /// connections under them stay open).
  void disconnect_set(const std::string& set);

  /// Activates a set: a flag flip, no socket opened. Pending pull requests of the set are answered. With
  /// `from`, only the links from that component (a node hosting several leaves switches each leaf's own).
  void activate(const std::string& set, const std::string& from = "");
  /// Deactivates a set (of `from` only, when given): a flag flip, no socket closed.
  void deactivate(const std::string& set, const std::string& from = "");
  /// True when `set` is active.
  bool active(const std::string& set) const;

  /// Sets the callback for data-plane events (broken connections, first overflow of an input).
  void on_event(std::function<void(const CommsEvent&)> fn);
  /// The clock of this endpoint's writers (ns): a stamped link (a tap's, host/net/tap.h) puts its time before each
  /// sample. Set it before making links (a link keeps the clock it was made with); unset, the stamp is 0.
  void set_clock(std::function<std::int64_t()> now);

  /// Lock-step delivery (docs/time.md, host/port.h LinkGate): with `on`, a sample pushed into this
  /// endpoint's inputs waits until release() counts it in. In-process and socket connections alike.
  void set_gated(bool on);
  /// Lock-step, for the clock master's owner (docs/time.md, "Samples to due nodes only"): a sample pushed on a
  /// socket connection whose destination component `hold` names is counted as sent but kept back, in order,
  /// until release_held() names that destination (or a later sample of the link is sent at once). Empty: none.
  void set_hold(std::function<bool(const std::string& to)> hold);
  /// Sends what was kept back for the components `to`, each connection's in order, in one write per socket.
  void release_held(const std::vector<std::string>& to);
  /// The samples kept back now, over every connection.
  std::size_t held() const;
  /// One push connection from this endpoint's outputs as the clock master counts it.
  struct SentCount {
    std::string to;   ///< the destination component
    std::string key;  ///< link_key(request)
    std::uint64_t sent;
  };
  /// Every push connection from this endpoint's outputs with the samples it has sent.
  std::vector<SentCount> sent_counts() const;
  /// True while a socket connection has bytes written but not yet taken by the kernel (its write queue).
  bool sending() const;
  /// Lets the first `n` samples of connection `key` (link_key) into their input; true when all `n` arrived.
  bool release(const std::string& key, std::uint64_t n);
  /// Samples arrived on connection `key` (0 when none yet).
  std::uint64_t received(const std::string& key) const;

  /// Every connection from this endpoint's outputs.
  std::vector<LinkInfo> links() const;
  /// Number of data connections accepted from other processes and still open (one per peer endpoint that
  /// opened one; links this endpoint makes towards such a peer ride it and open none).
  std::size_t accepted() const;
  /// Number of data connections open, whichever side opened them.
  std::size_t connections() const;
  /// Total bytes received on data connections.
  std::uint64_t bytes_received() const;
  /// Accepted data connections refused or closed before they were authenticated and introduced (failed or
  /// missing authentication, oversize or malformed frames, the handshake deadline), plus refused hellos.
  std::uint64_t refused() const;

  /// Internal state shared with connections (host/net/endpoint_internal.h).
  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
  std::string host_;
};

}  // namespace dca
