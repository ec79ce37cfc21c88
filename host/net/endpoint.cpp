// The Endpoint's pieces, in reading order: Connection (a link's sending side, any transport), Endpoint::Impl
// (components, sets, links, trunks, acceptors), DataSocket (data frames on a FramedSocket), LocalLink (an
// in-process link), StreamLink (the source of a link over a socket) and InLink (its destination), Trunk (the one
// socket connection between two endpoints that carries their links both ways), then the Endpoint's public
// operations.
#include "host/net/endpoint.h"

#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <map>
#include <stdexcept>
#include <unordered_map>

#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/steady_timer.hpp>

#include "host/codec/data_frame.h"
#include "host/net/framed_socket.h"

namespace asio = boost::asio;

namespace dca {
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
  std::map<std::string, std::unique_ptr<LinkGate>, std::less<>> gates;  // by link_key, never removed

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

Bytes as_bytes(std::string_view s) { return {reinterpret_cast<const std::byte*>(s.data()), s.size()}; }

std::string ms_text(std::chrono::milliseconds d) { return std::to_string(d.count()) + " ms"; }

// Frame I/O on one data socket (both ends use it): data frames on a FramedSocket, written at once when the
// socket takes them, queued up to kMaxBacklog bytes when it is backed up. Two deadlines, watched by one timer
// that is armed only when one is pending and never cancelled on the per-sample path: the handshake's (set by
// the accepting side) and the partial frame's (a frame begun and not completed within partial_timeout).
class DataSocket : public std::enable_shared_from_this<DataSocket>, private FramedSocket::Owner {
 public:
  DataSocket(Socket s, std::chrono::milliseconds partial_timeout)
      : framed_(std::move(s), *this), wake_(framed_.socket().get_executor()), partial_timeout_(partial_timeout) {}
  DataSocket(const DataSocket&) = delete;
  DataSocket& operator=(const DataSocket&) = delete;

  /// Sends a frame on `link`; false when the backlog is full (the frame is dropped) or the socket is closed.
  bool send(Kind kind, std::uint32_t link, Bytes body) {
    if (closed_ || failing_) return false;
    if (body.size() > data_frame::kMaxBody) return false;  // the peer would fail the connection (every link on it)
    if (!framed_.idle() && framed_.queued() > kMaxBacklog) return false;
    std::array<std::byte, data_frame::kHeader> h;
    data_frame::put_header(h.data(), kind, link, body.size());
    const std::array<std::string_view, 2> parts{
        std::string_view(reinterpret_cast<const char*>(h.data()), h.size()),
        std::string_view(reinterpret_cast<const char*>(body.data()), body.size())};
    if (corked_) {
      for (const auto& p : parts) batch_.append(p);
      return true;
    }
    return write(parts);
  }
  /// Gathers the frames sent until uncork() into one write (the frames that open a connection's links).
  void cork() { corked_ = true; }
  void uncork() {
    corked_ = false;
    if (!batch_.empty() && !closed_ && !failing_) {
      const std::array<std::string_view, 1> parts{batch_};
      write(parts);
    }
    batch_.clear();
  }
  /// Sends the handshake messages of one step.
  void send_auth(const auth::Handshake::Step& step) {
    for (const auto& m : step.out) send(Kind::Auth, 0, as_bytes(data_frame::encode_auth(m)));
  }

 private:
  bool write(std::span<const std::string_view> parts) {
    boost::system::error_code ec;
    if (framed_.write_now(parts, shared_from_this(), ec)) return true;
    // A write error breaks the connection from the loop, never inside the sender's call (which may be holding
    // one of the links that the break ends).
    failing_ = true;
    asio::post(framed_.socket().get_executor(), [self = shared_from_this(), why = ec.message()] { self->fail(why); });
    return false;
  }

 public:
  void start_read() {
    if (!closed_) framed_.read(shared_from_this());
  }

  /// Closes the socket; pending handlers find closed_ set and return.
  void shut() {
    if (closed_) return;
    closed_ = true;
    wake_.cancel();
    framed_.close();
  }

  /// Closes once everything queued is written (the error reply of a refused hello).
  void close_after_flush() {
    if (framed_.idle()) shut();
    else close_after_flush_ = true;
  }

  std::uint64_t bytes_out() const { return framed_.bytes_out(); }
  bool write_idle() const { return framed_.idle(); }
  bool closed() const { return closed_; }

 protected:
  virtual void on_frame(Kind kind, std::uint32_t link, Bytes body) = 0;
  virtual void on_broken(const std::string& reason) = 0;
  virtual void on_bytes(std::size_t) {}
  /// The largest frame the peer may send now (small until it has authenticated).
  virtual std::uint32_t frame_limit() const { return data_frame::kMaxFrame; }
  /// A malformed or oversize frame arrived: by default the connection breaks.
  virtual void on_malformed(const std::string& why) { fail("malformed data frame: " + why); }

  void fail(const std::string& reason) {
    if (closed_) return;
    shut();
    on_broken(reason);
  }

  /// The connection breaks unless clear_handshake_deadline() is called within `d` from now.
  void set_handshake_deadline(std::chrono::milliseconds d) {
    handshake_timeout_ = d;
    handshake_at_ = Clock::now() + d;
    wake_at(handshake_at_);
  }
  void clear_handshake_deadline() { handshake_at_ = Clock::time_point::max(); }

  Socket& sock() { return framed_.socket(); }

 private:
  void on_written(const boost::system::error_code& ec, std::size_t) override {
    if (closed_) return;
    if (ec) return fail(ec.message());
    if (framed_.queued() == 0 && close_after_flush_) shut();
  }

  void on_read(const boost::system::error_code& ec, std::size_t n) override {
    if (closed_) return;
    if (ec) return fail(ec == asio::error::eof ? "closed by peer" : ec.message());
    on_bytes(n);
    bool consumed = false;
    for (;;) {
      const auto unread = framed_.unread();
      data_frame::Frame f;
      std::size_t used = 0;
      std::string error;
      const auto r = data_frame::parse_frame({reinterpret_cast<const std::byte*>(unread.data()), unread.size()}, f,
                                             used, &error, frame_limit());
      if (r == data_frame::Parse::Error) return on_malformed(error);
      if (r == data_frame::Parse::NeedMore) break;
      on_frame(f.kind, f.link, f.body);
      if (closed_ || close_after_flush_) return;  // closed, or refused and closing
      framed_.consume(used);
      consumed = true;
    }
    watch_partial(consumed);
    start_read();
  }

  // A partial frame left in the buffer starts (or, after a whole frame, restarts) its deadline.
  void watch_partial(bool consumed) {
    if (framed_.unread().empty()) {
      partial_ = false;
      return;
    }
    if (partial_ && !consumed) return;
    partial_ = true;
    partial_since_ = Clock::now();
    wake_at(partial_since_ + partial_timeout_);
  }

  // Wakes at `at` unless already waking earlier; a re-armed timer's old wait finds its generation stale.
  void wake_at(Clock::time_point at) {
    if (closed_ || (waiting_ && wake_time_ <= at)) return;
    waiting_ = true;
    wake_time_ = at;
    wake_.expires_at(at);
    const auto gen = ++wake_gen_;
    std::weak_ptr<DataSocket> w = weak_from_this();
    wake_.async_wait([w, gen](const boost::system::error_code&) {
      if (auto s = w.lock(); s && gen == s->wake_gen_) s->on_wake();
    });
  }

  // Breaks the connection if a deadline passed, else waits for the next one pending.
  void on_wake() {
    waiting_ = false;
    if (closed_) return;
    const auto now = Clock::now();
    if (now >= handshake_at_) return fail("no authenticated introduction within " + ms_text(handshake_timeout_));
    const auto partial_at = partial_ ? partial_since_ + partial_timeout_ : Clock::time_point::max();
    if (now >= partial_at) return fail("a partial data frame was held for more than " + ms_text(partial_timeout_));
    const auto next = std::min(handshake_at_, partial_at);
    if (next != Clock::time_point::max()) wake_at(next);
  }

  FramedSocket framed_;
  asio::steady_timer wake_;
  std::uint64_t wake_gen_ = 0;
  Clock::time_point wake_time_{}, handshake_at_ = Clock::time_point::max(), partial_since_{};
  std::chrono::milliseconds partial_timeout_, handshake_timeout_{0};
  bool waiting_ = false, partial_ = false;
  bool closed_ = false, close_after_flush_ = false, failing_ = false, corked_ = false;
  std::string batch_;  // frames gathered while corked
};

// In-process connection: the sample is copied straight into the input.
class LocalLink final : public Connection, public PullSource, public InputFeeder {
 public:
  LocalLink(ConnectRequest r, Output* out, Input* in, std::shared_ptr<bool> active, LinkGate& gate)
      : Connection(std::move(r), Transport::InProcess, out, std::move(active)), in_(in), gate_(&gate) {
    in_->add_feeder(this);
    if (info_.request.mode == Mode::Pull) in_->add_pull_source(this);
    else in_->reserve_queue(info_.request.queue);
    out_->attach(this);
  }
  ~LocalLink() override { LocalLink::close(); }
  void on_write(Bytes b) override {
    if (info_.request.mode == Mode::Pull) {
      if (pending_ && *active_) answer();
      return;
    }
    if (!*active_ || !in_) {
      ++info_.skipped;
      return;
    }
    ++info_.sent;
    gate_->deliver(*in_, body(b));
  }
  void input_gone() override { in_ = nullptr; }
  void request() override {
    pending_ = true;
    if (*active_) answer();
  }
  void on_activate() override {
    if (pending_) answer();
  }
  void close() override {
    if (in_) {
      in_->remove_feeder(this);
      in_->remove_pull_source(this);
    }
    in_ = nullptr;
    Connection::close();
  }

 private:
  void answer() {
    if (!out_ || !in_ || !out_->has_latest()) return;
    pending_ = false;
    ++info_.sent;
    in_->deliver_pulled(out_->latest_bytes());
  }
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
  std::string hello() const {
    return data_frame::encode_hello({info_.request, out_ ? out_->spec() : PortSpec{}});
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

 private:
  void answer();
  bool oversized(Bytes b);
  void finish(const std::string& error);

  Endpoint::Impl* ep_;
  asio::steady_timer timer_;
  std::shared_ptr<Trunk> trunk_;
  std::uint32_t id_ = 0;
  Endpoint::ConnectDone done_;
  std::string peer_, peer_addr_;
  bool connected_ = false;
  bool pending_ = false;
  bool oversize_reported_ = false;
};

// The receiving side of a link over a socket: feeds one local input with what its trunk receives for it.
class InLink final : public PullSource, public InputFeeder {
 public:
  InLink(Trunk& trunk, std::uint32_t id, ConnectRequest r, Input* in, LinkGate& gate)
      : trunk_(&trunk), id_(id), r_(std::move(r)), in_(in), gate_(&gate) {
    in_->add_feeder(this);
    if (r_.mode == Mode::Pull) in_->add_pull_source(this);
    else in_->reserve_queue(r_.queue);
  }
  ~InLink() override { detach(); }
  InLink(const InLink&) = delete;
  InLink& operator=(const InLink&) = delete;

  void deliver(Kind kind, Bytes body) {
    if (!in_) return;
    if (kind == Kind::Sample) gate_->deliver(*in_, body);
    else in_->deliver_pulled(body);
  }
  void request() override;
  void input_gone() override;
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
  Trunk(Endpoint::Impl& ep, Socket s, Transport t, bool opener)
      : DataSocket(std::move(s), ep.opts.partial_frame_timeout),
        ep_(&ep),
        transport_(t),
        opener_(opener),
        handshake_(opener ? auth::Handshake::Role::kClient : auth::Handshake::Role::kServer, ep.data_key) {}

  /// The opener: connects to `where` (the address `addr`), authenticates and introduces this endpoint.
  void open(const StreamEndpoint& where, std::string addr) {
    addr_ = std::move(addr);
    set_handshake_deadline(ep_->opts.handshake_timeout);
    auto self = std::static_pointer_cast<Trunk>(shared_from_this());
    sock().async_connect(where, [self](const boost::system::error_code& ec) {
      if (self->closed()) return;
      if (ec) return self->down(Down::Connect, ec.message());
      self->set_up_socket();
      const auto step = self->handshake_.start();
      if (step.state == auth::Handshake::State::kFailed) return self->down(Down::NoKey, "");
      self->send_auth(step);
      self->start_read();
    });
  }
  /// The acceptor: waits for the opener's handshake, its introduction, then its links.
  void begin() {
    set_up_socket();
    set_handshake_deadline(ep_->opts.handshake_timeout);
    const auto step = handshake_.start();
    send_auth(step);
    if (step.state == auth::Handshake::State::kFailed) return refuse("this endpoint has no cluster key", false);
    start_read();
  }

  /// Adds a link from this endpoint's outputs: its hello goes now, or once this connection is ready.
  std::uint32_t add_out(StreamLink* l) {
    const std::uint32_t id = next_id_++;
    out_.emplace(id, l);
    if (ready_) send(Kind::Hello, id, as_bytes(l->hello()));
    return id;
  }
  /// Removes a link from this endpoint's outputs (the destination is told).
  void remove_out(std::uint32_t id) {
    if (out_.erase(id) != 0 && ready_) send(Kind::Close, id, {});
  }
  /// The input of the link `id` to this endpoint went away: the source is told, the link forgotten.
  void input_gone(std::uint32_t id, const std::string& why) {
    auto it = in_.find(id);
    if (it == in_.end()) return;
    auto gone = std::move(it->second);
    in_.erase(it);
    send(Kind::Gone, id, as_bytes(why));
  }
  /// Ends the links to the local component `name` (it is being removed).
  void remove_component(const std::string& name, const std::string& host) {
    std::vector<std::uint32_t> ids;
    for (const auto& [id, l] : in_)
      if (l->request_of().to == name) ids.push_back(id);
    for (auto id : ids) input_gone(id, name + " was removed from host " + host);
  }
  /// Closes the socket without reporting anything (the endpoint is going away).
  void close_quietly() {
    ep_ = nullptr;
    for (auto& [id, l] : in_) l->detach();
    in_.clear();
    out_.clear();
    shut();
  }

  /// Moves the links from this endpoint's outputs that have sent nothing yet to `to` (the destination is told
  /// they moved: no `broken`); then an opener left idle closes.
  void move_links_to(const std::shared_ptr<Trunk>& to);

  /// The other endpoint's data address over this transport ("" until an accepted connection is introduced).
  const std::string& address() const { return addr_; }
  Transport transport() const { return transport_; }
  bool opener() const { return opener_; }
  bool ready() const { return ready_; }
  /// True when `addr` over `t` is this open connection's other end.
  bool leads_to(Transport t, const std::string& addr) const {
    return transport_ == t && !closed() && ep_ != nullptr && !addr.empty() && addr_ == addr;
  }

 protected:
  void on_bytes(std::size_t n) override {
    if (ep_) ep_->bytes_received += n;
  }
  void on_frame(Kind kind, std::uint32_t link, Bytes body) override {
    if (!ep_) return;
    if (ready_) return on_link_frame(kind, link, body);
    if (!authenticated_) return on_auth(kind, body);
    if (!opener_) return on_peer(kind, body);
    fail("unexpected data frame kind " + std::to_string(static_cast<int>(kind)) + " before the handshake ended");
  }
  std::uint32_t frame_limit() const override {
    return authenticated_ ? data_frame::kMaxFrame : data_frame::kMaxAuthFrame;
  }
  void on_malformed(const std::string& why) override {
    if (authenticated_ || opener_) return fail("malformed data frame: " + why);
    refuse("authentication required: " + why, true);
  }
  void on_broken(const std::string& reason) override { down(Down::Closed, reason); }

 private:
  void set_up_socket() {
    boost::system::error_code ignored;
    if (transport_ == Transport::Tcp) sock().set_option(asio::ip::tcp::no_delay(true), ignored);
    sock().non_blocking(true, ignored);
  }

  // Before authentication only handshake messages are taken (an opener also takes its refusal).
  void on_auth(Kind kind, Bytes body) {
    if (opener_ && kind == Kind::HelloError)
      return down(Down::Refused, std::string(reinterpret_cast<const char*>(body.data()), body.size()));
    if (kind != Kind::Auth) {
      if (opener_) return down(Down::Auth, "the peer sent a data frame before the handshake ended");
      return refuse("authentication required: the cluster-key handshake comes first", true);
    }
    wire::Message m;
    std::string error;
    if (!data_frame::decode_auth(body, m, &error)) {
      if (opener_) return down(Down::Auth, error);
      return refuse(error, true);
    }
    const auto step = handshake_.on_message(m);
    send_auth(step);
    if (step.state == auth::Handshake::State::kFailed) {
      if (opener_) return down(Down::Auth, handshake_.reason());
      return refuse(handshake_.reason(), false);
    }
    if (step.state != auth::Handshake::State::kDone) return;
    authenticated_ = true;
    if (opener_) introduce();
  }
  // The opener, authenticated: says who it is, then opens the links waiting for this connection.
  void introduce() {
    cork();  // the introduction and the hellos waiting for it go in one write
    send(Kind::Peer, 0, as_bytes(data_frame::encode_peer({ep_->host, ep_->uds_path, ep_->tcp_address})));
    ready_ = true;
    clear_handshake_deadline();
    ep_->converge(transport_, addr_);  // may move this connection's links to the peer's (then this one closes)
    for (const auto& [id, l] : std::map<std::uint32_t, StreamLink*>(out_)) send(Kind::Hello, id, as_bytes(l->hello()));
    uncork();
    close_if_idle();
  }
  // The acceptor, authenticated: the opener's introduction comes first.
  void on_peer(Kind kind, Bytes body) {
    Location peer;
    std::string error;
    if (kind != Kind::Peer) error = "the first data frame after the handshake must introduce the peer";
    else data_frame::decode_peer(body, peer, &error);
    if (!error.empty()) return refuse(error, true);
    addr_ = transport_ == Transport::Unix ? peer.data_uds : peer.data_tcp;
    ready_ = true;
    clear_handshake_deadline();
    ep_->converge(transport_, addr_);
  }

  void on_link_frame(Kind kind, std::uint32_t id, Bytes body) {
    switch (kind) {
      case Kind::Sample:
      case Kind::Pulled:
        if (auto it = in_.find(id); it != in_.end()) it->second->deliver(kind, body);
        return;  // a link closed meanwhile: its last samples are dropped
      case Kind::Hello:
        return on_hello(id, body);
      case Kind::Close:
        return close_in(id, std::string_view(reinterpret_cast<const char*>(body.data()), body.size()) == kMoved);
      case Kind::HelloOk:
      case Kind::HelloError:
      case Kind::PullRequest:
      case Kind::Gone:
        return on_answer(kind, id, body);
      default:
        break;
    }
    fail("unexpected data frame kind " + std::to_string(static_cast<int>(kind)));
  }
  // A frame for a link from this endpoint's outputs (ignored when the link was removed meanwhile); a refusal on
  // link 0 refuses the whole connection.
  void on_answer(Kind kind, std::uint32_t id, Bytes body) {
    if (kind == Kind::HelloError && id == 0)
      return down(Down::Refused, std::string(reinterpret_cast<const char*>(body.data()), body.size()));
    auto it = out_.find(id);
    if (it == out_.end()) return;
    StreamLink* l = it->second;
    const std::string text(reinterpret_cast<const char*>(body.data()), body.size());
    if (kind == Kind::HelloOk) return l->accepted();
    if (kind == Kind::PullRequest) return l->pull_requested();
    out_.erase(it);
    if (kind == Kind::HelloError) l->refused(text);
    else l->trunk_down(Down::Closed, text);
  }
  // A new link to this endpoint: checked against its inputs.
  void on_hello(std::uint32_t id, Bytes body) {
    if (in_.count(id) != 0) return fail("a second hello for link " + std::to_string(id));
    data_frame::Hello h;
    std::string error;
    Input* in = nullptr;
    if (in_.size() >= kMaxLinks) error = "too many links on one connection";
    else if (data_frame::decode_hello(body, h, &error)) error = ep_->check_destination(h.request, h.out, in);
    if (!error.empty()) {
      ++ep_->refused;
      send(Kind::HelloError, id, as_bytes(error));
      return;
    }
    in_.emplace(id, std::make_unique<InLink>(*this, id, h.request, in, ep_->gate(link_key(h.request), true)));
    send(Kind::HelloOk, id, {});
  }
  // The source removed link `id` (reported where it ends, as when its connection closes), or moved it to the
  // other connection between the two endpoints (it has sent nothing here: nothing to report).
  void close_in(std::uint32_t id, bool moved) {
    auto it = in_.find(id);
    if (it == in_.end()) return;
    auto l = std::move(it->second);
    in_.erase(it);
    if (!moved) report_in(*ep_, *l, "closed by peer");
  }
  // An opener that carries no link (they moved or went) closes: false when it does not.
  bool close_if_idle() {
    if (!opener_ || !ready_ || !out_.empty() || !in_.empty() || !ep_) return false;
    auto keep = shared_from_this();
    std::exchange(ep_, nullptr)->drop_trunk(this);
    uncork();  // the introduction goes first: the peer then sees an introduced connection close
    shut();
    return true;
  }
  static void report_in(Endpoint::Impl& ep, const InLink& l, const std::string& reason) {
    const auto& r = l.request_of();
    ep.report({CommsEvent::Kind::Broken, r.to, r.in, r.from + "." + r.out, r.set, reason});
  }

  // The connection ended: every link on it ends too, each reported (or answered, while opening) at its end.
  void down(Down how, const std::string& reason) {
    auto* ep = std::exchange(ep_, nullptr);
    shut();
    if (!ep) return;
    if (!opener_ && !ready_) ++ep->refused;  // accepted, never introduced
    auto keep = shared_from_this();
    ep->drop_trunk(this);
    for (auto& [id, l] : std::exchange(in_, {})) {
      l->detach();
      report_in(*ep, *l, reason);
    }
    for (const auto& [id, l] : std::exchange(out_, {})) l->trunk_down(how, reason);
  }
  // Refuses the opener (counted): tells it `why` in a HelloError on link 0 when `tell`, closes once that is
  // written (the handshake deadline still bounds the wait) and leaves the endpoint.
  void refuse(const std::string& why, bool tell) {
    auto* ep = std::exchange(ep_, nullptr);
    if (!ep) return;
    ++ep->refused;
    if (tell) send(Kind::HelloError, 0, as_bytes(why));
    close_after_flush();
    ep->drop_trunk(this);
  }

  static constexpr std::size_t kMaxLinks = 1u << 16;  // links from the peer on one connection
  static constexpr std::string_view kMoved = "moved";  // a Close's body when the link moved

  Endpoint::Impl* ep_;
  Transport transport_;
  bool opener_;
  auth::Handshake handshake_;
  std::string addr_;
  bool authenticated_ = false;
  bool ready_ = false;  // authenticated and introduced: links may open
  std::uint32_t next_id_ = 1;
  std::map<std::uint32_t, StreamLink*> out_;  // links from this endpoint's outputs, by this endpoint's id
  std::unordered_map<std::uint32_t, std::unique_ptr<InLink>> in_;  // links to this endpoint, by the peer's id
};

void Trunk::move_links_to(const std::shared_ptr<Trunk>& to) {
  for (const auto& [id, l] : std::map<std::uint32_t, StreamLink*>(out_)) {
    if (!l->movable()) continue;
    out_.erase(id);
    if (ready_) send(Kind::Close, id, as_bytes(kMoved));
    l->move_to(to);
  }
  close_if_idle();
}

void InLink::request() { trunk_->send(Kind::PullRequest, id_, {}); }

void InLink::input_gone() {
  in_ = nullptr;
  trunk_->input_gone(id_, "input " + r_.to + "." + r_.in + " is gone");  // destroys this
}

void StreamLink::start(std::shared_ptr<Trunk> trunk, const std::string& addr, Endpoint::ConnectDone done,
                       int timeout_ms) {
  done_ = std::move(done);
  peer_ = info_.request.to + "." + info_.request.in;
  peer_addr_ = addr;
  trunk_ = std::move(trunk);
  std::weak_ptr<Connection> w = weak_from_this();
  timer_.expires_after(std::chrono::milliseconds(timeout_ms));
  timer_.async_wait([w, timeout_ms](const boost::system::error_code& ec) {
    auto self = std::static_pointer_cast<StreamLink>(w.lock());
    if (ec || !self || self->connected_ || !self->done_) return;
    self->finish("no answer from " + self->peer_ + " at " + self->peer_addr_ + " within " +
                 std::to_string(timeout_ms) + " ms");
  });
  id_ = trunk_->add_out(this);
}

void StreamLink::move_to(std::shared_ptr<Trunk> to) {
  trunk_ = std::move(to);
  id_ = trunk_->add_out(this);
}

void StreamLink::on_write(Bytes b) {
  if (!connected_ || info_.broken) return;
  if (info_.request.mode == Mode::Pull) {
    if (pending_ && *active_) answer();
    return;
  }
  if (!*active_) {
    ++info_.skipped;
    return;
  }
  const Bytes sample = body(b);
  if (oversized(sample)) return;
  if (trunk_->send(Kind::Sample, id_, sample)) {
    ++info_.sent;
    info_.bytes += data_frame::kHeader + sample.size();
  } else {
    ++info_.tx_dropped;
  }
}

void StreamLink::close() {
  Connection::close();
  ep_ = nullptr;
  timer_.cancel();
  if (auto t = std::exchange(trunk_, nullptr)) t->remove_out(id_);
}

void StreamLink::accepted() {
  if (connected_) return;
  connected_ = true;
  timer_.cancel();
  if (done_) std::exchange(done_, nullptr)("");
  if (pending_ && *active_) answer();
}

void StreamLink::trunk_down(Down how, const std::string& reason) {
  trunk_ = nullptr;
  if (done_) {
    switch (how) {
      case Down::Connect:
        return finish("cannot connect to " + peer_ + " at " + peer_addr_ + ": " + reason);
      case Down::NoKey:
        return finish("cannot connect to " + peer_ + ": this endpoint has no cluster key");
      case Down::Auth:
        return finish("data connection to " + peer_ + " at " + peer_addr_ + " not authenticated: " + reason);
      case Down::Refused:
        return finish(reason);
      case Down::Closed:
        return finish("connection to " + peer_ + " closed before it was accepted: " + reason);
    }
  }
  connected_ = false;
  info_.broken = true;
  if (ep_)
    ep_->report({CommsEvent::Kind::Broken, info_.request.from, info_.request.out, peer_, info_.request.set, reason});
}

void StreamLink::answer() {
  if (!out_ || !out_->has_latest() || !trunk_) return;
  pending_ = false;
  const Bytes b = out_->latest_bytes();
  if (oversized(b)) return;
  if (trunk_->send(Kind::Pulled, id_, b)) {
    ++info_.sent;
    info_.bytes += data_frame::kHeader + b.size();
  }
}

// A sample too big for one data frame is dropped here, counted in tx_dropped and reported once per link, as an
// overflow: sent, it would make the peer fail the whole connection, every link between the two processes.
bool StreamLink::oversized(Bytes b) {
  if (b.size() <= data_frame::kMaxBody) return false;
  ++info_.tx_dropped;
  if (!std::exchange(oversize_reported_, true) && ep_)
    ep_->report({CommsEvent::Kind::Overflow, info_.request.from, info_.request.out, peer_, info_.request.set,
                 "sample of " + std::to_string(b.size()) + " bytes exceeds the data frame limit of " +
                     std::to_string(data_frame::kMaxBody) + " bytes: dropped (counted in tx_dropped)"});
  return true;
}

// Opening failed: report once, then remove this link.
void StreamLink::finish(const std::string& error) {
  auto done = std::exchange(done_, nullptr);
  auto* ep = ep_;
  timer_.cancel();
  if (auto t = std::exchange(trunk_, nullptr)) t->remove_out(id_);
  if (ep) ep->remove_link(this);
  if (done) done(error);
}

}  // namespace endpoint_detail

using endpoint_detail::LocalLink;
using endpoint_detail::StreamLink;
using endpoint_detail::Trunk;

// ------------------------------------------------------------------------------------------------ Endpoint ---

std::shared_ptr<Trunk> Endpoint::Impl::trunk_to(Transport t, const std::string& addr, std::string* error) {
  std::shared_ptr<Trunk> found;  // the oldest of the preferred kind, else the oldest
  const bool here = prefer_opened_here(t, addr);
  for (const auto& tr : trunks)
    if (tr->leads_to(t, addr) && (!found || (found->opener() != here && tr->opener() == here))) found = tr;
  if (found) return found;
  const auto to = t == Transport::Unix ? std::optional(Address::unix_socket(addr)) : Address::parse(addr, error);
  const auto where = to ? to_endpoint(*to, error) : std::nullopt;
  if (!where) return nullptr;
  auto tr = std::make_shared<Trunk>(*this, Socket(io), t, true);
  trunks.push_back(tr);
  tr->open(*where, addr);
  return tr;
}

void Endpoint::Impl::converge(Transport t, const std::string& addr) {
  std::shared_ptr<Trunk> preferred;  // the oldest ready one of the preferred kind
  for (const auto& tr : trunks)
    if (!preferred && tr->leads_to(t, addr) && tr->ready() && tr->opener() == prefer_opened_here(t, addr))
      preferred = tr;
  if (!preferred) return;
  for (const auto& tr : std::vector<std::shared_ptr<Trunk>>(trunks))
    if (tr != preferred && tr->leads_to(t, addr)) tr->move_links_to(preferred);
}

void Endpoint::Impl::accept(StreamAcceptor& acceptor, AcceptBackoff& backoff) {
  acceptor.async_accept([this, &acceptor, &backoff](const boost::system::error_code& ec, Socket s) {
    if (ec == asio::error::operation_aborted || closing) return;
    if (ec) {  // EMFILE and friends: back off instead of spinning, said on stderr at a bounded rate
      const auto say = [](const std::string& line) { std::fprintf(stderr, "dca: %s\n", line.c_str()); };
      return backoff.failed(ec, "a data port on host " + host, say, [this, &acceptor, &backoff] {
        if (!closing) accept(acceptor, backoff);
      });
    }
    backoff.succeeded();
    boost::system::error_code e2;
    const Transport t = s.local_endpoint(e2).protocol().family() == AF_UNIX ? Transport::Unix : Transport::Tcp;
    auto tr = std::make_shared<Trunk>(*this, std::move(s), t, false);
    trunks.push_back(tr);
    tr->begin();
    accept(acceptor, backoff);
  });
}

Endpoint::Endpoint(asio::io_context& io, std::string host, EndpointOptions options)
    : impl_(std::make_unique<Impl>(io, host, std::move(options))), host_(std::move(host)) {}

Endpoint::~Endpoint() {
  impl_->closing = true;
  boost::system::error_code ec;
  impl_->uds_backoff.cancel();
  impl_->tcp_backoff.cancel();
  if (impl_->uds_acceptor) impl_->uds_acceptor->close(ec);
  if (impl_->tcp_acceptor) impl_->tcp_acceptor->close(ec);
  if (!impl_->uds_path.empty()) ::unlink(impl_->uds_path.c_str());
  for (auto& l : impl_->links) l->close();
  for (auto& t : std::vector<std::shared_ptr<Trunk>>(impl_->trunks)) t->close_quietly();
}

void Endpoint::listen(const std::string& uds_path, const std::string& tcp_address) {
  std::string error;
  Address bound;
  if (!uds_path.empty()) {
    impl_->uds_acceptor = std::make_unique<StreamAcceptor>(impl_->io);
    if (!listen_at(*impl_->uds_acceptor, Address::unix_socket(uds_path), &bound, &error))
      throw std::runtime_error(error);
    impl_->uds_path = uds_path;
    impl_->accept(*impl_->uds_acceptor, impl_->uds_backoff);
  }
  if (!tcp_address.empty()) {
    const auto at = Address::parse(tcp_address, &error);
    impl_->tcp_acceptor = std::make_unique<StreamAcceptor>(impl_->io);
    if (!at || !listen_at(*impl_->tcp_acceptor, *at, &bound, &error)) throw std::runtime_error(error);
    impl_->tcp_address = bound.str();
    impl_->accept(*impl_->tcp_acceptor, impl_->tcp_backoff);
  }
}

Location Endpoint::location() const { return {host_, impl_->uds_path, impl_->tcp_address}; }

void Endpoint::add_component(const std::string& name, PortSet& ports) {
  if (impl_->components.count(name)) throw std::invalid_argument("component '" + name + "' is already registered");
  impl_->components.emplace(name, &ports);
  for (const auto& in : ports.inputs()) {
    Input* p = in.get();
    p->on_overflow = [this, name, p] {
      impl_->report({CommsEvent::Kind::Overflow, name, p->name(), "", "",
                     "queue of " + std::to_string(p->capacity()) + " full: dropping the oldest samples (counted)"});
    };
  }
}

void Endpoint::remove_component(const std::string& name) {
  auto it = impl_->components.find(name);
  if (it == impl_->components.end()) return;
  for (const auto& in : it->second->inputs()) in->on_overflow = nullptr;
  std::vector<std::shared_ptr<Connection>> keep;
  for (auto& l : impl_->links) {
    if (l->request().from == name || (l->info().transport == Transport::InProcess && l->request().to == name)) l->close();
    else keep.push_back(l);
  }
  impl_->links.swap(keep);
  for (auto& t : std::vector<std::shared_ptr<Trunk>>(impl_->trunks)) t->remove_component(name, host_);
  impl_->components.erase(it);
}

PortSet* Endpoint::component(std::string_view name) const {
  auto it = impl_->components.find(name);
  return it == impl_->components.end() ? nullptr : it->second;
}

void Endpoint::connect(const ConnectRequest& r, const Location& dest, ConnectDone done, int timeout_ms) {
  auto* from = component(r.from);
  if (!from) return done("no component '" + r.from + "' at " + host_);
  Output* out = from->find_output(r.out);
  if (!out) return done(from->no_such_output(r.from, r.out));
  const Transport t = choose_transport(host_, component(r.to) != nullptr, dest);
  const std::string addr = t == Transport::Unix ? dest.data_uds : t == Transport::Tcp ? dest.data_tcp : "";
  for (const auto& l : impl_->links) {
    const auto& q = l->request();
    if (q.from != r.from || q.out != r.out || q.to != r.to || q.in != r.in || q.set != r.set) continue;
    // The same connection is the one already made, unless it broke or its destination now lives elsewhere
    // (a restarted process) or is another instance at the same address (a leaf removed and added again in a
    // shared node, whose `Gone` for the old link may still be on its way): then it is replaced.
    if (!l->info().broken && l->address() == addr && l->dest_instance == dest.instance) return done("");
    impl_->remove_link(l.get());
    break;
  }
  auto flag = impl_->set_flag(r.from, r.set);
  if (auto pre = impl_->sets.find(Impl::flag_key("", r.set)); pre != impl_->sets.end() && *pre->second) *flag = true;
  if (t == Transport::InProcess) {
    Input* in = nullptr;
    const std::string error = impl_->check_destination(r, out->spec(), in);
    if (!error.empty()) return done(error);
    impl_->links.push_back(std::make_shared<LocalLink>(r, out, in, flag, impl_->gate(link_key(r), true)));
    impl_->links.back()->dest_instance = dest.instance;
    impl_->links.back()->clock = impl_->clock;
    return done("");
  }
  std::string error;
  auto trunk = impl_->trunk_to(t, addr, &error);
  if (!trunk) return done("cannot connect to " + r.to + "." + r.in + ": " + error);
  auto link = std::make_shared<StreamLink>(*impl_, r, t, out, flag);
  link->dest_instance = dest.instance;
  link->clock = impl_->clock;
  out->attach(link.get());
  impl_->links.push_back(link);
  link->start(std::move(trunk), addr, std::move(done), timeout_ms);
}

void Endpoint::disconnect_set(const std::string& set) {
  std::vector<std::shared_ptr<Connection>> keep;
  for (auto& l : impl_->links) {
    if (l->request().set == set) l->close();
    else keep.push_back(l);
  }
  impl_->links.swap(keep);
}

void Endpoint::activate(const std::string& set, const std::string& from) {
  impl_->switch_set(set, from, true);
  for (std::size_t i = 0; i < impl_->links.size(); ++i)
    if (impl_->links[i]->request().set == set && (from.empty() || impl_->links[i]->request().from == from))
      impl_->links[i]->on_activate();
}

void Endpoint::deactivate(const std::string& set, const std::string& from) { impl_->switch_set(set, from, false); }

void Endpoint::on_event(std::function<void(const CommsEvent&)> fn) { impl_->on_event = std::move(fn); }

void Endpoint::set_clock(std::function<std::int64_t()> now) { impl_->clock = std::move(now); }

bool Endpoint::active(const std::string& set) const {
  for (const auto& [key, flag] : impl_->sets)
    if (*flag && key.size() > set.size() && key.compare(key.size() - set.size(), set.size(), set) == 0 &&
        key[key.size() - set.size() - 1] == '\x1f')
      return true;
  return false;
}

void Endpoint::set_gated(bool on) {
  impl_->gated = on;
  for (auto& [key, g] : impl_->gates) g->gated = on;
}

bool Endpoint::sending() const {
  for (const auto& t : impl_->trunks)
    if (!t->write_idle()) return true;
  return false;
}

std::vector<Endpoint::SentCount> Endpoint::sent_counts() const {
  std::vector<SentCount> v;
  for (const auto& l : impl_->links)
    if (l->request().mode == Mode::Push) v.push_back({l->request().to, link_key(l->request()), l->info().sent});
  return v;
}

// The input a gate feeds: the destination component's input named in the key ("from|out>to|in@set").
static Input* gate_input(const Endpoint::Impl& ep, const std::string& key) {
  const auto gt = key.find('>'), at = key.rfind('@');
  if (gt == std::string::npos || at == std::string::npos || at < gt) return nullptr;
  const std::string dest = key.substr(gt + 1, at - gt - 1);
  const auto bar = dest.find('|');
  if (bar == std::string::npos) return nullptr;
  auto it = ep.components.find(std::string_view(dest).substr(0, bar));
  return it == ep.components.end() ? nullptr : it->second->find_input(std::string_view(dest).substr(bar + 1));
}

bool Endpoint::release(const std::string& key, std::uint64_t n) {
  return impl_->gate(key, false).release(gate_input(*impl_, key), n);
}

std::uint64_t Endpoint::received(const std::string& key) const {
  auto it = impl_->gates.find(key);
  return it == impl_->gates.end() ? 0 : it->second->received();
}

std::vector<LinkInfo> Endpoint::links() const {
  std::vector<LinkInfo> v;
  for (const auto& l : impl_->links) v.push_back(l->info());
  return v;
}

std::size_t Endpoint::accepted() const {
  return static_cast<std::size_t>(
      std::count_if(impl_->trunks.begin(), impl_->trunks.end(), [](const auto& t) { return !t->opener(); }));
}
std::size_t Endpoint::connections() const { return impl_->trunks.size(); }
std::uint64_t Endpoint::bytes_received() const { return impl_->bytes_received; }
std::uint64_t Endpoint::refused() const { return impl_->refused; }

}  // namespace dca
