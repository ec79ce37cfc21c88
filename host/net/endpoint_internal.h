#pragma once
// host/net: sockets on the io_context (Asio). Never Beast, never host/web.
// The Endpoint's pieces (host/net/endpoint.h), shared by its three files and by nothing else. In reading order:
// Connection (a link's sending side, any transport), Endpoint::Impl (components, sets, links, trunks, acceptors),
// DataSocket (data frames on a FramedSocket), LocalLink (an in-process link), StreamLink (the source of a link
// over a socket) and InLink (its destination), Trunk (the one socket connection between two endpoints that
// carries their links both ways). endpoint.cpp holds the Endpoint's public operations, endpoint_trunk.cpp the
// DataSocket and the Trunk, endpoint_links.cpp the three links.
#include "host/net/endpoint.h"

#include <array>
#include <chrono>
#include <cstring>
#include <map>
#include <optional>
#include <span>
#include <unordered_map>
#include <utility>

#include <boost/asio/steady_timer.hpp>

#include "host/codec/data_frame.h"
#include "host/net/framed_socket.h"

namespace dca {

namespace asio = boost::asio;
namespace endpoint_detail {

// A connection's sending side, whatever its transport: gets every sample written to its output.
class Connection : public Link, public std::enable_shared_from_this<Connection> {
 public:
  Connection(ConnectRequest r, Transport t, Output* out, std::shared_ptr<bool> active)
      : out_(out), active_(std::move(active)) {
    info_.request = std::move(r);
    info_.transport = t;
  }
  Connection(const Connection&) = delete;
  Connection& operator=(const Connection&) = delete;
  /// The set became active.
  virtual void on_activate() {}
  /// Detaches from both ends and closes any socket.
  void close() override {
    if (out_) out_->detach(this);
    out_ = nullptr;
  }
  LinkInfo info() const {
    LinkInfo i = info_;
    i.active = *active_;
    return i;
  }
  const ConnectRequest& request() const { return info_.request; }
  /// The destination leaf's instance (Location::instance) when the link was made.
  std::uint64_t dest_instance = 0;
  /// The destination's data address ("" in-process).
  virtual const std::string& address() const {
    static const std::string none;
    return none;
  }
  /// A stamped link's clock: the writer's time put before each sample (Endpoint::set_clock; host/net/tap.h).
  std::function<std::int64_t()> clock;

 protected:
  /// What travels for the sample `b`: `b` itself, or on a stamped link the writer's time (8 bytes, host order)
  /// then `b` (allocates only when a sample is bigger than any before).
  Bytes body(Bytes b) {
    if (!info_.request.stamped) return b;
    const std::int64_t t = clock ? clock() : 0;
    if (stamped_.size() < sizeof t + b.size()) stamped_.resize(sizeof t + b.size());
    std::memcpy(stamped_.data(), &t, sizeof t);
    if (!b.empty()) std::memcpy(stamped_.data() + sizeof t, b.data(), b.size());
    return {stamped_.data(), sizeof t + b.size()};
  }

  Output* out_;
  std::shared_ptr<bool> active_;
  LinkInfo info_;
  std::vector<std::byte> stamped_;
};

using Socket = FramedSocket::Socket;
using data_frame::Kind;
class Trunk;

}  // namespace endpoint_detail

using endpoint_detail::Connection;
using endpoint_detail::Socket;
namespace endpoint_detail { class StreamLink; }

struct Endpoint::Impl {
  Impl(asio::io_context& io_, std::string host_, EndpointOptions o)
      : io(io_),
        host(std::move(host_)),
        opts(std::move(o)),
        data_key(dca::data_key(opts.key)),
        uds_backoff(io_),
        tcp_backoff(io_) {}
  asio::io_context& io;
  std::string host;
  EndpointOptions opts;
  auth::Key data_key;  // the handshake's key on data sockets (dca::data_key)
  std::map<std::string, PortSet*, std::less<>> components;
  std::map<std::string, std::shared_ptr<bool>, std::less<>> sets;
  std::vector<std::shared_ptr<Connection>> links;
  std::vector<std::shared_ptr<endpoint_detail::Trunk>> trunks;  // socket connections to other endpoints, open
  std::unique_ptr<StreamAcceptor> uds_acceptor, tcp_acceptor;
  AcceptBackoff uds_backoff, tcp_backoff;  // one each: a retry timer per acceptor
  std::string uds_path, tcp_address;
  std::uint64_t bytes_received = 0;
  std::uint64_t refused = 0;
  bool closing = false;
  bool gated = false;  // lock-step delivery (set_gated)
  std::function<bool(const std::string& to)> hold;  // lock-step, the clock's owner: samples kept back (set_hold)
  std::vector<endpoint_detail::StreamLink*> holding;  // the links with samples kept back
  std::map<std::string, std::unique_ptr<LinkGate>, std::less<>> gates;  // by link_key, never removed
  // In each hello this endpoint sends: its random id and how many it sent before (data_frame::Hello)
  const std::uint64_t sender = random_sender();
  std::uint64_t hellos = 0;

  // A nonzero random id within data_frame::kMaxSerial (the operating system's random source, auth::random_bytes).
  static std::uint64_t random_sender() {
    const std::string b = auth::random_bytes(sizeof(std::uint64_t));
    std::uint64_t v = 0;
    std::memcpy(&v, b.data(), sizeof v);
    v &= data_frame::kMaxSerial;
    return v == 0 ? 1 : v;
  }

  /// The gate of connection `key` (made on first use; a connection made again under the same name starts
  /// its counts again).
  LinkGate& gate(const std::string& key, bool fresh) {
    auto& g = gates[key];
    if (!g) g = std::make_unique<LinkGate>();
    else if (fresh && g->received() > 0) g->reset();
    g->gated = gated;
    return *g;
  }

  // One flag per source component and set: in a node hosting several leaves, a set switched at one of them
  // (its own control channel) never switches the others' links, whichever channel is read first.
  static std::string flag_key(const std::string& from, const std::string& set) { return from + '\x1f' + set; }
  std::shared_ptr<bool> set_flag(const std::string& from, const std::string& name) {
    const std::string key = flag_key(from, name);
    auto it = sets.find(key);
    if (it != sets.end()) return it->second;
    return sets.emplace(key, std::make_shared<bool>(false)).first->second;
  }
  // Sets every flag of `set` (of source `from` only, when given) to `on`.
  void switch_set(const std::string& set, const std::string& from, bool on) {
    if (!from.empty()) {
      *set_flag(from, set) = on;
      return;
    }
    bool any = false;
    for (auto& [key, flag] : sets)
      if (key.size() > set.size() && key.compare(key.size() - set.size(), set.size(), set) == 0 &&
          key[key.size() - set.size() - 1] == '\x1f') {
        *flag = on;
        any = true;
      }
    if (!any) *set_flag("", set) = on;
  }
  void report(CommsEvent e) {
    if (on_event && !closing) on_event(e);
  }
  void remove_link(Connection* l) {
    for (auto it = links.begin(); it != links.end(); ++it)
      if (it->get() == l) {
        auto keep = *it;  // the link may be running one of its own handlers
        links.erase(it);
        keep->close();
        return;
      }
  }
  /// Validates a connection's destination: "" when `r.to`.`r.in` exists here and accepts `out`.
  std::string check_destination(const ConnectRequest& r, const PortSpec& out, Input*& in) const {
    auto it = components.find(r.to);
    if (it == components.end()) return "no component '" + r.to + "' at " + host;
    in = it->second->find_input(r.in);
    if (!in) return it->second->no_such_input(r.to, r.in);
    if (r.stamped) return is_tap_input(in->spec()) ? "" : "a tap's link goes to a tap input, not to '" + r.in + "'";
    return compatibility_error(out, in->spec());
  }
  /// Accepts data connections on `acceptor` until it closes, each into a Trunk; failures back off.
  void accept(StreamAcceptor& acceptor, AcceptBackoff& backoff);
  /// The open connection to the endpoint at `addr` over `t` (opened by either side), or a new one opening;
  /// nullptr with *error when `addr` is not an address.
  std::shared_ptr<endpoint_detail::Trunk> trunk_to(Transport t, const std::string& addr, std::string* error);
  /// Forgets a connection that closed.
  void drop_trunk(const endpoint_detail::Trunk* t) {
    std::erase_if(trunks, [t](const auto& p) { return p.get() == t; });
  }
  /// Which connection to the endpoint at `addr` links prefer when two endpoints opened one each (they did so at
  /// the same instant): the one opened by the endpoint whose own address sorts first. Both ends agree.
  bool prefer_opened_here(Transport t, const std::string& addr) const {
    return (t == Transport::Unix ? uds_path : tcp_address) < addr;
  }
  /// Moves the links to `addr` that have sent nothing yet onto the preferred connection, once it is ready.
  void converge(Transport t, const std::string& addr);

  std::function<void(const CommsEvent&)> on_event;
  std::function<std::int64_t()> clock;  // the time stamped links put before their samples (set_clock)
};

namespace endpoint_detail {

constexpr std::size_t kMaxBacklog = 8u << 20;  // bytes waiting on a backed-up socket before samples are dropped
using Clock = std::chrono::steady_clock;

inline Bytes as_bytes(std::string_view s) { return {reinterpret_cast<const std::byte*>(s.data()), s.size()}; }

// Frame I/O on one data socket (both ends use it): data frames on a FramedSocket, written at once when the
// socket takes them, queued up to kMaxBacklog bytes when it is backed up. Two deadlines, watched by one timer
// that is armed only when one is pending and never cancelled on the per-sample path: the handshake's (set by
// the accepting side) and the partial frame's (a frame begun and not completed within partial_timeout).
class DataSocket : public std::enable_shared_from_this<DataSocket>, private FramedSocket::Owner {
 public:
  /// A data socket's life: Open -> (Failing | Flushing) -> Closed.
  enum class Phase : std::uint8_t {
    Open,      ///< sends and receives
    Failing,   ///< a write failed: sends nothing more; the break is posted to the loop (fail)
    Flushing,  ///< refused the peer: reads nothing more, closes once its queue is written (close_after_flush)
    Closed,    ///< socket and timer closed; pending handlers return
  };
  DataSocket(Socket s, std::chrono::milliseconds partial_timeout)
      : framed_(std::move(s), *this), wake_(framed_.socket().get_executor()), partial_timeout_(partial_timeout) {}
  DataSocket(const DataSocket&) = delete;
  DataSocket& operator=(const DataSocket&) = delete;

  /// Sends a frame on `link`; false when the backlog is full (the frame is dropped) or the socket is closed.
  bool send(Kind kind, std::uint32_t link, Bytes body);
  /// Gathers the frames sent until uncork() into one write (the frames that open a connection's links).
  void cork() {
    if (!batch_) batch_.emplace();
  }
  void uncork();
  /// Sends the handshake messages of one step.
  void send_auth(const auth::Handshake::Step& step);

 private:
  bool write(std::span<const std::string_view> parts);
  /// True while frames may still be sent (Open or Flushing).
  bool sending() const { return phase_ == Phase::Open || phase_ == Phase::Flushing; }

 public:
  void start_read();

  /// Closes the socket; pending handlers find the phase Closed and return.
  void shut();

  /// Closes once everything queued is written (the error reply of a refused hello).
  void close_after_flush();

  std::uint64_t bytes_out() const { return framed_.bytes_out(); }
  bool write_idle() const { return framed_.idle(); }
  bool closed() const { return phase_ == Phase::Closed; }

 protected:
  virtual void on_frame(Kind kind, std::uint32_t link, Bytes body) = 0;
  virtual void on_broken(const std::string& reason) = 0;
  virtual void on_bytes(std::size_t) {}
  /// The largest frame the peer may send now (small until it has authenticated).
  virtual std::uint32_t frame_limit() const { return data_frame::kMaxFrame; }
  /// A malformed or oversize frame arrived: by default the connection breaks.
  virtual void on_malformed(const std::string& why) { fail("malformed data frame: " + why); }

  void fail(const std::string& reason);

  /// The connection breaks unless clear_handshake_deadline() is called within `d` from now.
  void set_handshake_deadline(std::chrono::milliseconds d);
  void clear_handshake_deadline() { handshake_at_ = Clock::time_point::max(); }

  Socket& sock() { return framed_.socket(); }

 private:
  void on_written(const boost::system::error_code& ec, std::size_t) override;

  void on_read(const boost::system::error_code& ec, std::size_t n) override;

  // A partial frame left in the buffer starts (or, after a whole frame, restarts) its deadline.
  void watch_partial(bool consumed);

  // Wakes at `at` unless already waking earlier; a re-armed timer's old wait finds its generation stale.
  void wake_at(Clock::time_point at);

  // Breaks the connection if a deadline passed, else waits for the next one pending.
  void on_wake();

  FramedSocket framed_;
  asio::steady_timer wake_;
  std::uint64_t wake_gen_ = 0;
  // The deadlines (max: none pending) and the timer's wake-up (max: not waiting).
  Clock::time_point wake_time_ = Clock::time_point::max(), handshake_at_ = Clock::time_point::max(),
                    partial_at_ = Clock::time_point::max();
  std::chrono::milliseconds partial_timeout_, handshake_timeout_{0};
  Phase phase_ = Phase::Open;
  std::optional<std::string> batch_;  // while corked: the frames gathered
};

class LocalLink final : public Connection, public PullSource, public InputFeeder {
 public:
  LocalLink(ConnectRequest r, Output* out, Input* in, std::shared_ptr<bool> active, LinkGate& gate)
      : Connection(std::move(r), Transport::InProcess, out, std::move(active)), in_(in), gate_(&gate) {
    gate_->adopt(this);
    in_->add_feeder(this);
    if (info_.request.mode == Mode::Pull) in_->add_pull_source(this);
    else in_->reserve_queue(info_.request.queue);
    out_->attach(this);
  }
  ~LocalLink() override { LocalLink::close(); }
  void on_write(Bytes b) override;
  void input_gone() override { in_ = nullptr; }
  std::string writer() const override { return info_.request.from + "." + info_.request.out; }
  void request() override;
  void on_activate() override;
  void close() override;

 private:
  void answer();
  Input* in_;
  LinkGate* gate_;
  bool pending_ = false;
};

// How a link's connection failed before the destination accepted it (worded by StreamLink::trunk_down).
enum class Down : std::uint8_t {
  Connect,   // the socket did not connect
  NoKey,     // this endpoint has no cluster key
  Auth,      // the handshake failed
  Refused,   // the destination refused the connection; the reason is its own words
  Closed,    // the connection closed or broke
};

// The sending side of a link over a socket: its hello, then samples, on the Trunk to the destination's endpoint.
class StreamLink final : public Connection {
 public:
  StreamLink(Endpoint::Impl& ep, ConnectRequest r, Transport t, Output* out, std::shared_ptr<bool> active)
      : Connection(std::move(r), t, out, std::move(active)), ep_(&ep), timer_(ep.io) {}
  ~StreamLink() override { StreamLink::close(); }

  /// Opens the link on `trunk` (to the endpoint at `addr`); `done` runs once: after the hello's answer, a
  /// refusal, a failure of the connection, or `timeout_ms`.
  void start(std::shared_ptr<Trunk> trunk, const std::string& addr, Endpoint::ConnectDone done, int timeout_ms);

  /// The Hello body that opens this link.
  std::string hello() {
    data_frame::Hello h{info_.request, out_ ? out_->spec() : PortSpec{}};
    if (ep_) {
      h.sender = ep_->sender;
      h.serial = ep_->hellos++;
    }
    return data_frame::encode_hello(h);
  }

  void on_write(Bytes b) override;
  void on_activate() override {
    if (pending_ && connected_) answer();
  }
  const std::string& address() const override { return peer_addr_; }
  void close() override;

  // From the trunk: the destination's answers and requests for this link.
  void accepted();
  void refused(const std::string& why) { finish(why); }
  void pull_requested() {
    if (!connected_) return;
    pending_ = true;
    if (*active_) answer();
  }
  /// The link ended at the destination (its input went away) or the connection under it did.
  void trunk_down(Down how, const std::string& reason);
  /// True when the link may move to another connection to its destination: it has sent nothing yet (so no
  /// sample of it can overtake another).
  bool movable() const { return info_.sent == 0 && !info_.broken; }
  /// Continues on `to` (its hello goes there).
  void move_to(std::shared_ptr<Trunk> to);
  /// The connection under this link (nullptr when down).
  Trunk* trunk() const { return trunk_.get(); }
  /// Lock-step: sends the samples kept back (Endpoint::set_hold), in order; they were counted as sent.
  void release_held();
  /// The samples kept back.
  std::size_t held() const { return held_sizes_.size(); }

 private:
  void answer();
  bool oversized(Bytes b);
  void finish(const std::string& error);
  void drop_held();

  Endpoint::Impl* ep_;
  asio::steady_timer timer_;
  std::shared_ptr<Trunk> trunk_;
  std::uint32_t id_ = 0;
  Endpoint::ConnectDone done_;
  std::string peer_, peer_addr_;
  bool connected_ = false;
  bool pending_ = false;
  bool oversize_reported_ = false;
  std::vector<std::byte> held_;            // the samples kept back, one after another
  std::vector<std::uint32_t> held_sizes_;  // their sizes, in order
};

// The receiving side of a link over a socket: feeds one local input with what its trunk receives for it.
class InLink final : public PullSource, public InputFeeder {
 public:
  // `h`'s link; the gate's owner unless an earlier hello of its sender (LinkGate::later)
  InLink(Trunk& trunk, std::uint32_t id, const data_frame::Hello& h, Input* in, LinkGate& gate)
      : trunk_(&trunk), id_(id), r_(h.request), in_(in), gate_(&gate) {
    if (gate_->later(h.sender, h.serial)) gate_->adopt(this, h.sender, h.serial);
    in_->add_feeder(this);
    if (r_.mode == Mode::Pull) in_->add_pull_source(this);
    else in_->reserve_queue(r_.queue);
  }
  ~InLink() override { detach(); }
  InLink(const InLink&) = delete;
  InLink& operator=(const InLink&) = delete;

  void deliver(Kind kind, Bytes body) {
    if (!in_) return;
    if (kind == Kind::Sample) gate_->deliver(*in_, body, this);
    else in_->deliver_pulled(body);
  }
  void request() override;
  void input_gone() override;
  std::string writer() const override { return r_.from + "." + r_.out; }
  /// Stops feeding the input.
  void detach() {
    if (in_) {
      in_->remove_feeder(this);
      in_->remove_pull_source(this);
    }
    in_ = nullptr;
  }
  const ConnectRequest& request_of() const { return r_; }

 private:
  Trunk* trunk_;
  std::uint32_t id_;
  ConnectRequest r_;
  Input* in_;
  LinkGate* gate_;
};

// One socket connection between this endpoint and another, opened by either: the cluster-key handshake (Auth
// frames; the opener is the handshake's client), the opener's introduction (Peer: its own data addresses, so
// that the acceptor's links towards it find this connection), then every link between the two endpoints, both
// ways, each frame naming its link (host/codec/data_frame.h). A link refused by the destination leaves the
// connection open; a malformed frame, a write error or the peer closing ends it, and with it every link on it,
// each reported `broken` where it ends. Idle, it stays open for the life of both endpoints.
class Trunk final : public DataSocket {
 public:
  /// A trunk's set-up: Authenticating -> Introducing -> Ready (an opener passes Introducing at once: it
  /// introduces itself). Whether it is closed is the DataSocket's phase.
  enum class Phase : std::uint8_t {
    Authenticating,  ///< only handshake frames (Auth; an opener also takes a refusal), bounded by kMaxAuthFrame
    Introducing,     ///< authenticated; the acceptor waits for the opener's Peer frame
    Ready,           ///< authenticated and introduced: links open and carry samples, both ways
  };
  Trunk(Endpoint::Impl& ep, Socket s, Transport t, bool opener)
      : DataSocket(std::move(s), ep.opts.partial_frame_timeout),
        ep_(&ep),
        transport_(t),
        opener_(opener),
        handshake_(opener ? auth::Handshake::Role::kClient : auth::Handshake::Role::kServer, ep.data_key) {}

  /// The opener: connects to `where` (the address `addr`), authenticates and introduces this endpoint.
  void open(const StreamEndpoint& where, std::string addr);
  /// The acceptor: waits for the opener's handshake, its introduction, then its links.
  void begin();

  /// Adds a link from this endpoint's outputs: its hello goes now, or once this connection is ready.
  std::uint32_t add_out(StreamLink* l);
  /// Removes a link from this endpoint's outputs (the destination is told).
  void remove_out(std::uint32_t id);
  /// The input of the link `id` to this endpoint went away: the source is told, the link forgotten.
  void input_gone(std::uint32_t id, const std::string& why);
  /// Ends the links to the local component `name` (it is being removed).
  void remove_component(const std::string& name, const std::string& host);
  /// Closes the socket without reporting anything (the endpoint is going away).
  void close_quietly();

  /// Moves the links from this endpoint's outputs that have sent nothing yet to `to` (the destination is told
  /// they moved: no `broken`); then an opener left idle closes.
  void move_links_to(const std::shared_ptr<Trunk>& to);

  /// The other endpoint's data address over this transport ("" until an accepted connection is introduced).
  const std::string& address() const { return addr_; }
  Transport transport() const { return transport_; }
  bool opener() const { return opener_; }
  bool ready() const { return phase_ == Phase::Ready; }
  /// True when `addr` over `t` is this open connection's other end.
  bool leads_to(Transport t, const std::string& addr) const;

 protected:
  void on_bytes(std::size_t n) override;
  void on_frame(Kind kind, std::uint32_t link, Bytes body) override;
  std::uint32_t frame_limit() const override;
  void on_malformed(const std::string& why) override;
  void on_broken(const std::string& reason) override { down(Down::Closed, reason); }

 private:
  void set_up_socket();

  // Before authentication only handshake messages are taken (an opener also takes its refusal).
  void on_auth(Kind kind, Bytes body);
  // The opener, authenticated: says who it is, then opens the links waiting for this connection.
  void introduce();
  // The acceptor, authenticated: the opener's introduction comes first.
  void on_peer(Kind kind, Bytes body);

  void on_link_frame(Kind kind, std::uint32_t id, Bytes body);
  // A frame for a link from this endpoint's outputs (ignored when the link was removed meanwhile); a refusal on
  // link 0 refuses the whole connection.
  void on_answer(Kind kind, std::uint32_t id, Bytes body);
  // A new link to this endpoint: checked against its inputs.
  void on_hello(std::uint32_t id, Bytes body);
  // The source removed link `id` (reported where it ends, as when its connection closes), or moved it to the
  // other connection between the two endpoints (it has sent nothing here: nothing to report).
  void close_in(std::uint32_t id, bool moved);
  // An opener that carries no link (they moved or went) closes: false when it does not.
  bool close_if_idle();
  static void report_in(Endpoint::Impl& ep, const InLink& l, const std::string& reason);

  // The connection ended: every link on it ends too, each reported (or answered, while opening) at its end.
  void down(Down how, const std::string& reason);
  // Refuses the opener (counted): tells it `why` in a HelloError on link 0 when `tell`, closes once that is
  // written (the handshake deadline still bounds the wait) and leaves the endpoint.
  void refuse(const std::string& why, bool tell);

  static constexpr std::size_t kMaxLinks = 1u << 16;  // links from the peer on one connection
  static constexpr std::string_view kMoved = "moved";  // a Close's body when the link moved

  Endpoint::Impl* ep_;
  Transport transport_;
  const bool opener_;  // this endpoint opened it (the handshake's client); else it accepted it
  auth::Handshake handshake_;
  std::string addr_;
  Phase phase_ = Phase::Authenticating;
  std::uint32_t next_id_ = 1;
  std::map<std::uint32_t, StreamLink*> out_;  // links from this endpoint's outputs, by this endpoint's id
  std::unordered_map<std::uint32_t, std::unique_ptr<InLink>> in_;  // links to this endpoint, by the peer's id
};

}  // namespace endpoint_detail
}  // namespace dca
