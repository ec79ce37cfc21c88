// The Endpoint's pieces, in reading order: Connection (a link's sending side, any transport), Endpoint::Impl
// (components, sets, links, sessions, acceptors), DataSocket (data frames on a FramedSocket), the three kinds
// of connection end (LocalLink: in-process; StreamLink: the source of a socket connection; Session: its
// destination), then the Endpoint's public operations.
#include "host/endpoint.h"

#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <set>
#include <stdexcept>

#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/steady_timer.hpp>

#include "host/data_frame.h"
#include "host/framed_socket.h"

namespace asio = boost::asio;

namespace dca {
namespace endpoint_detail {

// A connection's sending side, whatever its transport: gets every sample written to its output.
class Connection : public Link {
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
  /// The destination's data address ("" in-process).
  virtual const std::string& address() const {
    static const std::string none;
    return none;
  }

 protected:
  Output* out_;
  std::shared_ptr<bool> active_;
  LinkInfo info_;
};

using Socket = FramedSocket::Socket;
using data_frame::Kind;
class Session;

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
  std::set<std::shared_ptr<endpoint_detail::Session>> sessions;
  std::unique_ptr<StreamAcceptor> uds_acceptor, tcp_acceptor;
  AcceptBackoff uds_backoff, tcp_backoff;  // one each: a retry timer per acceptor
  std::string uds_path, tcp_address;
  std::uint64_t bytes_received = 0;
  std::uint64_t refused = 0;
  bool closing = false;

  std::shared_ptr<bool> set_flag(const std::string& name) {
    auto it = sets.find(name);
    if (it != sets.end()) return it->second;
    return sets.emplace(name, std::make_shared<bool>(false)).first->second;
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
    return compatibility_error(out, in->spec());
  }
  /// Accepts data connections on `acceptor` until it closes, each into a Session; failures back off.
  void accept(StreamAcceptor& acceptor, AcceptBackoff& backoff);
  void start_session(Socket s);

  std::function<void(const CommsEvent&)> on_event;
};

namespace endpoint_detail {

constexpr std::size_t kMaxBacklog = 8u << 20;  // bytes waiting on a backed-up socket before samples are dropped
using Clock = std::chrono::steady_clock;

Bytes as_bytes(const std::string& s) { return {reinterpret_cast<const std::byte*>(s.data()), s.size()}; }

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

  /// Sends a frame; false when the backlog is full (the frame is dropped) or the socket is closed.
  bool send(Kind kind, Bytes body) {
    if (closed_) return false;
    if (!framed_.idle() && framed_.queued() > kMaxBacklog) return false;
    std::array<std::byte, data_frame::kHeader> h;
    data_frame::put_header(h.data(), kind, body.size());
    const std::array<std::string_view, 2> parts{
        std::string_view(reinterpret_cast<const char*>(h.data()), h.size()),
        std::string_view(reinterpret_cast<const char*>(body.data()), body.size())};
    boost::system::error_code ec;
    if (framed_.write_now(parts, shared_from_this(), ec)) return true;
    fail(ec.message());
    return false;
  }
  /// Sends the handshake messages of one step.
  void send_auth(const auth::Handshake::Step& step) {
    for (const auto& m : step.out) send(Kind::Auth, as_bytes(data_frame::encode_auth(m)));
  }

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
  bool closed() const { return closed_; }

 protected:
  virtual void on_frame(Kind kind, Bytes body) = 0;
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
      on_frame(f.kind, f.body);
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
    if (now >= handshake_at_) return fail("no authenticated hello within " + ms_text(handshake_timeout_));
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
  bool closed_ = false, close_after_flush_ = false;
};

// In-process connection: the sample is copied straight into the input.
class LocalLink final : public Connection, public PullSource, public InputFeeder {
 public:
  LocalLink(ConnectRequest r, Output* out, Input* in, std::shared_ptr<bool> active)
      : Connection(std::move(r), Transport::InProcess, out, std::move(active)), in_(in) {
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
    in_->deliver(b);
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
  bool pending_ = false;
};

// The sending side of a socket connection: connect, authenticate (Auth frames), hello, then samples.
class StreamLink final : public Connection, public DataSocket {
 public:
  StreamLink(Endpoint::Impl& ep, ConnectRequest r, Transport t, Output* out, std::shared_ptr<bool> active)
      : Connection(std::move(r), t, out, std::move(active)),
        DataSocket(Socket(ep.io), ep.opts.partial_frame_timeout),
        ep_(&ep),
        timer_(ep.io),
        handshake_(auth::Handshake::Role::kClient, ep.data_key) {}

  /// Connects to `dest`; `done` runs once, after the hello's answer, a refusal or `timeout_ms`.
  void start(const Location& dest, Endpoint::ConnectDone done, int timeout_ms) {
    done_ = std::move(done);
    peer_ = info_.request.to + "." + info_.request.in;
    std::string error;
    const auto to = info_.transport == Transport::Unix ? std::optional(Address::unix_socket(dest.data_uds))
                                                       : Address::parse(dest.data_tcp, &error);
    const auto where = to ? to_endpoint(*to, &error) : std::nullopt;
    if (!where) return finish("cannot connect to " + peer_ + ": " + error);
    peer_addr_ = info_.transport == Transport::Unix ? dest.data_uds : dest.data_tcp;
    auto self = std::static_pointer_cast<StreamLink>(shared_from_this());
    timer_.expires_after(std::chrono::milliseconds(timeout_ms));
    timer_.async_wait([self, timeout_ms](const boost::system::error_code& ec) {
      if (ec || self->connected_ || !self->done_) return;
      self->finish("no answer from " + self->peer_ + " at " + self->peer_addr_ + " within " +
                   std::to_string(timeout_ms) + " ms");
    });
    sock().async_connect(*where, [self](const boost::system::error_code& ec) {
      if (self->closed() || !self->done_) return;
      if (ec) return self->finish("cannot connect to " + self->peer_ + " at " + self->peer_addr_ + ": " + ec.message());
      self->authenticate();
    });
  }

  void on_write(Bytes b) override {
    if (!connected_ || info_.broken) return;
    if (info_.request.mode == Mode::Pull) {
      if (pending_ && *active_) answer();
      return;
    }
    if (!*active_) {
      ++info_.skipped;
      return;
    }
    if (send(Kind::Sample, b)) ++info_.sent;
    else ++info_.tx_dropped;
    info_.bytes = bytes_out();
  }

  void on_activate() override {
    if (pending_ && connected_) answer();
  }
  const std::string& address() const override { return peer_addr_; }

  void close() override {
    Connection::close();
    ep_ = nullptr;
    timer_.cancel();
    shut();
  }

 protected:
  void on_frame(Kind kind, Bytes body) override {
    switch (kind) {
      case Kind::Auth:
        if (authenticated_) break;
        return on_auth(body);
      case Kind::HelloOk:
        if (connected_ || !authenticated_) break;
        connected_ = true;
        timer_.cancel();
        if (done_) std::exchange(done_, nullptr)("");
        if (pending_ && *active_) answer();
        return;
      case Kind::HelloError:
        return finish(std::string(reinterpret_cast<const char*>(body.data()), body.size()));
      case Kind::PullRequest:
        if (!connected_) break;
        pending_ = true;
        if (*active_) answer();
        return;
      default:
        break;
    }
    fail("unexpected data frame kind " + std::to_string(static_cast<int>(kind)) + " from " + peer_);
  }

  std::uint32_t frame_limit() const override {
    return authenticated_ ? data_frame::kMaxFrame : data_frame::kMaxAuthFrame;
  }

  void on_broken(const std::string& reason) override {
    if (done_) return finish("connection to " + peer_ + " closed before it was accepted: " + reason);
    info_.broken = true;
    if (ep_)
      ep_->report({CommsEvent::Kind::Broken, info_.request.from, info_.request.out, peer_, info_.request.set,
                   reason});
  }

 private:
  // Connected: sets the socket up and sends the handshake's hello (an endpoint without a key stops here).
  void authenticate() {
    boost::system::error_code ignored;
    if (info_.transport == Transport::Tcp) {
      const int one = 1;
      ::setsockopt(sock().native_handle(), IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    }
    sock().non_blocking(true, ignored);
    const auto step = handshake_.start();
    if (step.state == auth::Handshake::State::kFailed)
      return finish("cannot connect to " + peer_ + ": this endpoint has no cluster key");
    send_auth(step);
    start_read();
  }

  // One handshake message from the destination; once authenticated, the data hello.
  void on_auth(Bytes body) {
    wire::Message m;
    std::string error;
    if (!data_frame::decode_auth(body, m, &error)) return finish(refused(error));
    const auto step = handshake_.on_message(m);
    send_auth(step);
    if (step.state == auth::Handshake::State::kFailed) return finish(refused(handshake_.reason()));
    if (step.state != auth::Handshake::State::kDone) return;
    authenticated_ = true;
    data_frame::Hello h{info_.request, out_ ? out_->spec() : PortSpec{}};
    send(Kind::Hello, as_bytes(data_frame::encode_hello(h)));
  }
  std::string refused(const std::string& why) const {
    return "data connection to " + peer_ + " at " + peer_addr_ + " not authenticated: " + why;
  }

  void answer() {
    if (!out_ || !out_->has_latest()) return;
    pending_ = false;
    if (send(Kind::Pulled, out_->latest_bytes())) ++info_.sent;
    info_.bytes = bytes_out();
  }
  // Connect failed: report once, then remove this link.
  void finish(const std::string& error) {
    auto done = std::exchange(done_, nullptr);
    auto* ep = ep_;
    timer_.cancel();
    shut();
    if (ep) ep->remove_link(this);
    if (done) done(error);
  }

  Endpoint::Impl* ep_;
  asio::steady_timer timer_;
  auth::Handshake handshake_;
  Endpoint::ConnectDone done_;
  std::string peer_, peer_addr_;
  bool authenticated_ = false;
  bool connected_ = false;
  bool pending_ = false;
};

// The receiving side of a socket connection: authenticates the source, checks its hello, then feeds one local
// input. Anything else before the hello is refused with a reason; the session then leaves the endpoint.
class Session final : public DataSocket, public PullSource, public InputFeeder {
 public:
  Session(Endpoint::Impl& ep, Socket s)
      : DataSocket(std::move(s), ep.opts.partial_frame_timeout),
        ep_(&ep),
        handshake_(auth::Handshake::Role::kServer, ep.data_key) {}
  void begin() {
    boost::system::error_code ignored;
    sock().non_blocking(true, ignored);
    set_handshake_deadline(ep_->opts.handshake_timeout);
    const auto step = handshake_.start();
    send_auth(step);
    if (step.state == auth::Handshake::State::kFailed) return refuse("this endpoint has no cluster key", false);
    start_read();
  }
  void request() override { send(Kind::PullRequest, {}); }
  void input_gone() override {
    in_ = nullptr;
    ep_ = nullptr;
    shut();
  }
  void close() {
    if (in_) {
      in_->remove_feeder(this);
      in_->remove_pull_source(this);
    }
    in_ = nullptr;
    ep_ = nullptr;
    shut();
  }
  const std::string& to() const { return hello_.request.to; }

 protected:
  void on_bytes(std::size_t n) override {
    if (ep_) ep_->bytes_received += n;
  }
  void on_frame(Kind kind, Bytes body) override {
    if (!ep_) return;
    if (!authenticated_) return on_auth(kind, body);
    if (!in_) return on_hello(kind, body);
    if (kind == Kind::Sample) in_->deliver(body);
    else if (kind == Kind::Pulled) in_->deliver_pulled(body);
    else fail("unexpected data frame kind " + std::to_string(static_cast<int>(kind)));
  }
  std::uint32_t frame_limit() const override {
    return authenticated_ ? data_frame::kMaxFrame : data_frame::kMaxAuthFrame;
  }
  void on_malformed(const std::string& why) override {
    if (authenticated_) return fail("malformed data frame: " + why);
    refuse("authentication required: " + why, true);
  }
  void on_broken(const std::string& reason) override {
    auto* ep = ep_;
    if (!ep) return;
    if (in_)
      ep->report({CommsEvent::Kind::Broken, hello_.request.to, hello_.request.in,
                  hello_.request.from + "." + hello_.request.out, hello_.request.set, reason});
    else
      ++ep->refused;
    close();
    ep->sessions.erase(std::static_pointer_cast<Session>(shared_from_this()));
  }

 private:
  // Before authentication only handshake messages are taken.
  void on_auth(Kind kind, Bytes body) {
    if (kind != Kind::Auth) return refuse("authentication required: the cluster-key handshake comes first", true);
    wire::Message m;
    std::string error;
    if (!data_frame::decode_auth(body, m, &error)) return refuse(error, true);
    const auto step = handshake_.on_message(m);
    send_auth(step);
    if (step.state == auth::Handshake::State::kFailed) return refuse(handshake_.reason(), false);
    authenticated_ = step.state == auth::Handshake::State::kDone;
  }
  // The first frame after authentication: the hello, checked against this endpoint's inputs.
  void on_hello(Kind kind, Bytes body) {
    std::string error;
    if (kind != Kind::Hello) error = "the first data frame must be a hello";
    else if (data_frame::decode_hello(body, hello_, &error)) error = ep_->check_destination(hello_.request, hello_.out, in_);
    if (!error.empty()) return refuse(error, true);
    in_->add_feeder(this);
    if (hello_.request.mode == Mode::Pull) in_->add_pull_source(this);
    else in_->reserve_queue(hello_.request.queue);
    clear_handshake_deadline();
    send(Kind::HelloOk, {});
  }
  // Refuses the connection (counted): tells the peer `why` in a HelloError when `tell`, closes once that is
  // written (the handshake deadline still bounds the wait) and leaves the endpoint.
  void refuse(const std::string& why, bool tell) {
    auto* ep = std::exchange(ep_, nullptr);
    if (!ep) return;
    ++ep->refused;
    in_ = nullptr;
    if (tell) send(Kind::HelloError, as_bytes(why));
    close_after_flush();
    ep->sessions.erase(std::static_pointer_cast<Session>(shared_from_this()));
  }

  Endpoint::Impl* ep_;
  auth::Handshake handshake_;
  data_frame::Hello hello_;
  Input* in_ = nullptr;
  bool authenticated_ = false;
};

}  // namespace endpoint_detail

using endpoint_detail::LocalLink;
using endpoint_detail::Session;
using endpoint_detail::StreamLink;

// ------------------------------------------------------------------------------------------------ Endpoint ---

auth::Key data_key(const auth::Key& cluster_key) {
  if (cluster_key.empty()) return {};  // no key stays no key: the handshake then refuses
  return auth::hmac_sha256(cluster_key, "dca-data-1");
}

void Endpoint::Impl::start_session(Socket s) {
  auto session = std::make_shared<Session>(*this, std::move(s));
  sessions.insert(session);
  session->begin();
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
    {
      boost::system::error_code e2;
      if (s.local_endpoint(e2).protocol().family() != AF_UNIX) s.set_option(asio::ip::tcp::no_delay(true), e2);
      start_session(std::move(s));
    }
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
  for (auto& s : std::set<std::shared_ptr<Session>>(impl_->sessions)) s->close();
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
  for (auto& s : std::set<std::shared_ptr<Session>>(impl_->sessions))
    if (s->to() == name) {
      s->close();
      impl_->sessions.erase(s);
    }
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
    // (a restarted process): then it is replaced.
    if (!l->info().broken && l->address() == addr) return done("");
    impl_->remove_link(l.get());
    break;
  }
  auto flag = impl_->set_flag(r.set);
  if (t == Transport::InProcess) {
    Input* in = nullptr;
    const std::string error = impl_->check_destination(r, out->spec(), in);
    if (!error.empty()) return done(error);
    impl_->links.push_back(std::make_shared<LocalLink>(r, out, in, flag));
    return done("");
  }
  auto link = std::make_shared<StreamLink>(*impl_, r, t, out, flag);
  out->attach(link.get());
  impl_->links.push_back(link);
  link->start(dest, std::move(done), timeout_ms);
}

void Endpoint::disconnect_set(const std::string& set) {
  std::vector<std::shared_ptr<Connection>> keep;
  for (auto& l : impl_->links) {
    if (l->request().set == set) l->close();
    else keep.push_back(l);
  }
  impl_->links.swap(keep);
}

void Endpoint::activate(const std::string& set) {
  *impl_->set_flag(set) = true;
  for (std::size_t i = 0; i < impl_->links.size(); ++i)
    if (impl_->links[i]->request().set == set) impl_->links[i]->on_activate();
}

void Endpoint::deactivate(const std::string& set) { *impl_->set_flag(set) = false; }

void Endpoint::on_event(std::function<void(const CommsEvent&)> fn) { impl_->on_event = std::move(fn); }

bool Endpoint::active(const std::string& set) const {
  auto it = impl_->sets.find(set);
  return it != impl_->sets.end() && *it->second;
}

std::vector<LinkInfo> Endpoint::links() const {
  std::vector<LinkInfo> v;
  for (const auto& l : impl_->links) v.push_back(l->info());
  return v;
}

std::size_t Endpoint::accepted() const { return impl_->sessions.size(); }
std::uint64_t Endpoint::bytes_received() const { return impl_->bytes_received; }
std::uint64_t Endpoint::refused() const { return impl_->refused; }

}  // namespace dca
