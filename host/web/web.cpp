#include "host/web/web.h"

#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <deque>
#include <optional>
#include <set>
#include <vector>

#include "host/codec/hex.h"
#include "host/codec/json.h"
#include "host/net/auth.h"

namespace dca::web {

namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = boost::asio::ip::tcp;

// ------------------------------------------------------------------------------------------ text helpers

namespace {

std::string percent_decode(std::string_view s) {
  std::string out;
  for (std::size_t i = 0; i < s.size(); i++) {
    if (s[i] == '%' && i + 2 < s.size() && hex::digit(s[i + 1]) >= 0 && hex::digit(s[i + 2]) >= 0) {
      out += static_cast<char>(hex::digit(s[i + 1]) * 16 + hex::digit(s[i + 2]));
      i += 2;
    } else {
      out += s[i] == '+' ? ' ' : s[i];
    }
  }
  return out;
}

std::string_view path_of(std::string_view target) { return target.substr(0, target.find('?')); }

std::string_view sv(beast::string_view s) { return {s.data(), s.size()}; }

}  // namespace

std::string query_value(std::string_view target, std::string_view name) {
  const auto q = target.find('?');
  if (q == std::string_view::npos) return "";
  std::string_view rest = target.substr(q + 1);
  while (!rest.empty()) {
    const auto amp = rest.find('&');
    const std::string_view pair = rest.substr(0, amp);
    const auto eq = pair.find('=');
    if (pair.substr(0, eq) == name) return eq == std::string_view::npos ? "" : percent_decode(pair.substr(eq + 1));
    if (amp == std::string_view::npos) break;
    rest = rest.substr(amp + 1);
  }
  return "";
}

namespace {

class ServerImpl;

// ------------------------------------------------------------------------------------------ a WebSocket

// Per subscribed topic: the rate, the last kept sample's wall time, the rows kept since the last flush, and the
// newest sample the rate held back since then (sent once the interval has passed, or at a final flush: a topic's
// last sample is never lost, as a run that ends or pauses between two kept ones would lose it).
struct Subscription {
  double min_interval_s = 0;
  std::chrono::steady_clock::time_point last{};
  std::string rows;  // "[t,v,...],[t,v,...]"
  std::int64_t pending_t = -1;  // the sample held back (-1: none), formatted only if it is sent
  std::vector<double> pending;
};

void append_row(std::string& out, std::int64_t t_ns, std::span<const double> values) {
  out += '[';
  json::append_number(out, static_cast<double>(t_ns) / 1e9);
  for (double v : values) {
    out += ',';
    json::append_number(out, v);
  }
  out += ']';
}

class HttpSession;

class WsSession : public Connection, public std::enable_shared_from_this<WsSession> {
 public:
  WsSession(tcp::socket socket, std::weak_ptr<ServerImpl> server, std::uint64_t id, std::string protocol,
            std::shared_ptr<Protocol> handler, const Limits& limits, std::string peer)
      : ws_(std::move(socket)), server_(std::move(server)), id_(id), protocol_(std::move(protocol)),
        handler_(std::move(handler)), limits_(limits), peer_(std::move(peer)) {}

  void start(http::request<http::string_body> req);
  bool send(std::string data, bool binary, bool droppable) override;
  void close(const std::string& reason) override;
  bool is_open() const override { return open_; }
  void subscribe(std::uint32_t topic, double rate) override;
  std::uint64_t id() const override { return id_; }
  const std::string& protocol() const override { return protocol_; }
  const std::string& peer() const override { return peer_; }
  ConnectionStats stats() const override {
    ConnectionStats s = stats_;
    s.queued_bytes = queued_bytes_;
    return s;
  }
  /// A sample of a topic it may have subscribed to.
  void on_sample(const SampleHub::Topic& t, std::int64_t t_ns, std::span<const double> values);
  /// Sends what its subscriptions kept.
  void flush_samples(const SampleHub& hub, bool held = false);

 private:
  struct Out {
    std::string data;
    bool binary;
  };
  void read();
  void write_next();
  void closed(const std::string& reason);

  websocket::stream<tcp::socket> ws_;
  std::weak_ptr<ServerImpl> server_;
  std::uint64_t id_;
  std::string protocol_;
  std::shared_ptr<Protocol> handler_;
  Limits limits_;
  std::string peer_;
  beast::flat_buffer in_;
  std::deque<Out> queue_;
  std::size_t queued_bytes_ = 0;
  bool open_ = false, writing_ = false, ended_ = false, close_after_write_ = false;
  std::string close_reason_;
  ConnectionStats stats_;
  std::map<std::uint32_t, Subscription> subs_;
};

// ------------------------------------------------------------------------------------------ the server

class ServerImpl : public Server, public SampleHub::Observer {
 public:
  ServerImpl(boost::asio::io_context& io, Limits limits) : io_(io), acceptor_(io), flush_(io), limits_(limits) {}
  ~ServerImpl() override {
    close();  // its sessions end: each protocol is told, and lets go of its connections
    hub_.remove_observer(this);
  }

  bool start(const Address& at, std::string* error);
  Address address() const override { return bound_; }
  const std::string& token() const override { return token_; }
  void add_token(const std::string& t) override {
    if (!t.empty()) tokens_.insert(t);
  }
  void set_page(const std::string& path, Page page, bool public_page) override {
    pages_[path] = {std::move(page), public_page};
  }
  void add_protocol(const std::string& name, std::shared_ptr<Protocol> handler) override {
    if (default_protocol_.empty()) default_protocol_ = name;
    protocols_[name] = std::move(handler);
  }
  SampleHub& samples() override { return hub_; }
  std::map<std::uint64_t, Connection::Ptr> connections() const override;
  ServerStats stats() const override {
    ServerStats s = stats_;
    s.open = open_sockets_;
    s.authenticated = authenticated_;
    return s;
  }
  void flush_samples() override;
  void close() override;

  void on_sample(const SampleHub::Topic& t, std::int64_t t_ns, std::span<const double> values) override;
  // --- for the sessions
  bool authorized(const http::request<http::string_body>& req) const;
  http::response<http::string_body> answer(const http::request<http::string_body>& req);
  /// Why a WebSocket upgrade is refused (401, 400), or nothing with *chosen = its subprotocol.
  std::optional<http::response<http::string_body>> refusal(const http::request<http::string_body>& req,
                                                           std::string* chosen);
  void upgrade(tcp::socket socket, http::request<http::string_body> req, const std::string& chosen,
               const std::string& peer);
  /// A socket closed; `authenticated` when it had presented the token.
  void socket_closed(bool authenticated) {
    if (open_sockets_ > 0) open_sockets_--;
    if (authenticated && authenticated_ > 0) authenticated_--;
  }
  /// A pending socket presented the token: false (and nothing counted) when the token holders' sockets are full.
  bool admit() {
    if (authenticated_ >= limits_.max_connections) {
      stats_.over_limit++;
      return false;
    }
    authenticated_++;
    return true;
  }
  void ws_closed(std::uint64_t id) { sessions_.erase(id); }
  void count_bad() { stats_.bad_requests++; }
  void count_over_limit() { stats_.over_limit++; }
  const Limits& limits() const { return limits_; }
  void want_flush() {
    if (!flush_armed_) arm_flush();
  }

 private:
  void accept();
  void arm_flush();
  void add_pending(const std::shared_ptr<HttpSession>& h);

  boost::asio::io_context& io_;
  tcp::acceptor acceptor_;
  boost::asio::steady_timer flush_;
  bool flush_armed_ = false, closed_ = false;
  Limits limits_;
  Address bound_;
  std::string token_;
  std::set<std::string> tokens_;
  std::map<std::string, std::pair<Page, bool>> pages_;
  std::map<std::string, std::shared_ptr<Protocol>> protocols_;
  std::string default_protocol_;
  SampleHub hub_;
  std::map<std::uint64_t, std::weak_ptr<WsSession>> sessions_;
  std::uint64_t next_id_ = 1;
  std::size_t open_sockets_ = 0, authenticated_ = 0;
  std::deque<std::weak_ptr<HttpSession>> pending_;  // sockets yet to present the token, oldest first
  ServerStats stats_;
};

// ------------------------------------------------------------------------------------------ an HTTP session

class HttpSession : public std::enable_shared_from_this<HttpSession> {
 public:
  HttpSession(tcp::socket socket, std::weak_ptr<ServerImpl> server, std::string peer)
      : stream_(std::move(socket)), server_(std::move(server)), peer_(std::move(peer)) {}
  ~HttpSession() {
    if (auto s = server_.lock(); s && !upgraded_) s->socket_closed(authed_);
  }
  void read();
  /// Whether it presented the token (it has left the pending pool).
  bool authenticated() const { return authed_ || upgraded_; }
  /// Closes a pending socket to make room for a newer one.
  void evict() {
    beast::error_code ignored;
    stream_.socket().close(ignored);
  }

 private:
  void on_read(beast::error_code ec);
  void respond(http::response<http::string_body> res);

  beast::tcp_stream stream_;
  std::weak_ptr<ServerImpl> server_;
  std::string peer_;
  beast::flat_buffer buffer_{16 * 1024};
  std::optional<http::request_parser<http::string_body>> parser_;
  std::shared_ptr<http::response<http::string_body>> res_;
  bool upgraded_ = false, authed_ = false;
};

void HttpSession::read() {
  auto s = server_.lock();
  if (!s) return;
  parser_.emplace();
  parser_->header_limit(static_cast<std::uint32_t>(s->limits().max_request_bytes));
  parser_->body_limit(s->limits().max_request_bytes);
  stream_.expires_after(authed_ ? s->limits().request_timeout : s->limits().auth_timeout);
  http::async_read(stream_, buffer_, *parser_,
                   [self = shared_from_this()](beast::error_code ec, std::size_t) { self->on_read(ec); });
}

void HttpSession::on_read(beast::error_code ec) {
  auto s = server_.lock();
  if (!s) return;
  if (ec) {
    // a closed or timed-out socket is no error; anything else is a malformed or oversize request
    if (ec != http::error::end_of_stream && ec != beast::error::timeout && ec != boost::asio::error::eof &&
        ec != boost::asio::error::operation_aborted && ec != boost::asio::error::connection_reset) {
      if (ec == http::error::header_limit || ec == http::error::body_limit || ec == http::error::buffer_overflow)
        s->count_over_limit();
      else
        s->count_bad();
      http::response<http::string_body> res{http::status::bad_request, 11};
      res.set(http::field::content_type, "text/plain");
      res.body() = "bad request: " + ec.message() + "\n";
      res.keep_alive(false);
      res.prepare_payload();
      respond(std::move(res));
    }
    return;
  }
  auto req = parser_->release();
  if (!authed_ && s->authorized(req)) {
    if (!s->admit()) {
      http::response<http::string_body> res{http::status::service_unavailable, 11};
      res.set(http::field::content_type, "text/plain");
      res.body() = "too many connections\n";
      res.keep_alive(false);
      res.prepare_payload();
      respond(std::move(res));
      return;
    }
    authed_ = true;
  }
  if (websocket::is_upgrade(req)) {
    std::string chosen;
    if (auto no = s->refusal(req, &chosen)) {
      respond(std::move(*no));
      return;
    }
    stream_.expires_never();
    upgraded_ = true;
    s->upgrade(stream_.release_socket(), std::move(req), chosen, peer_);
    return;
  }
  respond(s->answer(req));
}

void HttpSession::respond(http::response<http::string_body> res) {
  res_ = std::make_shared<http::response<http::string_body>>(std::move(res));
  http::async_write(stream_, *res_, [self = shared_from_this()](beast::error_code ec, std::size_t) {
    if (ec || !self->res_->keep_alive()) {
      beast::error_code ignored;
      self->stream_.socket().shutdown(tcp::socket::shutdown_send, ignored);
      return;
    }
    self->res_.reset();
    self->read();
  });
}

// ------------------------------------------------------------------------------------------ WebSocket session

void WsSession::start(http::request<http::string_body> req) {
  auto s = server_.lock();
  if (!s) return;
  ws_.set_option(websocket::stream_base::timeout{limits_.request_timeout, websocket::stream_base::none(), false});
  const std::string proto = protocol_;
  const bool echo = !req[http::field::sec_websocket_protocol].empty();
  ws_.set_option(websocket::stream_base::decorator([proto, echo](websocket::response_type& res) {
    res.set(http::field::server, "dca");
    if (echo) res.set(http::field::sec_websocket_protocol, proto);
  }));
  ws_.read_message_max(limits_.max_message_bytes);
  ws_.async_accept(req, [self = shared_from_this()](beast::error_code ec) {
    if (ec) {
      self->closed("handshake: " + ec.message());
      return;
    }
    // an idle page is pinged; one that answers nothing within the idle timeout (a dead peer, a half-sent
    // frame) is closed
    self->ws_.set_option(websocket::stream_base::timeout{self->limits_.request_timeout,
                                                         self->limits_.idle_timeout, true});
    if (self->ended_) return;  // closed during the handshake (the server closed)
    self->open_ = true;
    self->handler_->on_open(self->shared_from_this());
    if (self->open_) self->read();
  });
}

void WsSession::read() {
  ws_.async_read(in_, [self = shared_from_this()](beast::error_code ec, std::size_t) {
    if (ec) {
      if (ec == websocket::error::message_too_big)
        if (auto s = self->server_.lock()) s->count_over_limit();
      self->closed(ec == websocket::error::closed ? "closed by the client" : ec.message());
      return;
    }
    self->stats_.received++;
    const std::string data = beast::buffers_to_string(self->in_.data());
    self->in_.consume(self->in_.size());
    const bool binary = self->ws_.got_binary();
    if (!self->open_) return;
    self->handler_->on_message(self->shared_from_this(), data, binary);
    if (self->open_) self->read();
  });
}

bool WsSession::send(std::string data, bool binary, bool droppable) {
  if (!open_) return false;
  const std::size_t n = data.size();
  if (droppable && queued_bytes_ + n > limits_.max_queue_bytes) {
    stats_.dropped++;
    return false;
  }
  if (queued_bytes_ + n > limits_.close_queue_bytes) {
    close("too slow: " + std::to_string(queued_bytes_) + " bytes not taken");
    return false;
  }
  queued_bytes_ += n;
  queue_.push_back({std::move(data), binary});
  if (!writing_) write_next();
  return true;
}

void WsSession::write_next() {
  if (queue_.empty()) {
    writing_ = false;
    if (close_after_write_) {
      close_after_write_ = false;
      ws_.async_close(websocket::close_code::normal, [self = shared_from_this()](beast::error_code) {});
    }
    return;
  }
  writing_ = true;
  ws_.binary(queue_.front().binary);
  ws_.async_write(boost::asio::buffer(queue_.front().data), [self = shared_from_this()](beast::error_code ec,
                                                                                           std::size_t n) {
    self->queued_bytes_ -= self->queue_.front().data.size();
    self->queue_.pop_front();
    if (ec) {
      self->closed("write: " + ec.message());
      return;
    }
    self->stats_.sent++;
    self->stats_.sent_bytes += n;
    self->write_next();
  });
}

void WsSession::close(const std::string& reason) {
  if (!open_) return;
  const bool slow = reason.rfind("too slow", 0) == 0;
  closed(reason);
  if (slow) {  // a stalled write would hold a polite close forever: cut the socket
    beast::error_code ignored;
    ws_.next_layer().close(ignored);
  } else if (writing_) {
    close_after_write_ = true;
  } else {
    ws_.async_close(websocket::close_code::normal, [self = shared_from_this()](beast::error_code) {});
  }
}

void WsSession::closed(const std::string& reason) {
  if (ended_) return;
  ended_ = true;
  const bool was_open = open_;
  open_ = false;
  subs_.clear();
  auto self = shared_from_this();
  if (auto s = server_.lock()) {
    s->ws_closed(id_);
    s->socket_closed(true);  // a WebSocket presented the token (its upgrade was admitted)
  }
  // the handler is let go of: a protocol that keeps its connections (as most do) would otherwise hold this
  // session, which holds it, for ever
  const auto handler = std::move(handler_);
  if (was_open && handler) handler->on_close(self, reason);
}

void WsSession::subscribe(std::uint32_t topic, double rate) {
  if (rate <= 0) {
    subs_.erase(topic);
    return;
  }
  subs_[topic].min_interval_s = 1.0 / std::min(rate, 1000.0);
  if (auto s = server_.lock()) s->want_flush();
}

void WsSession::on_sample(const SampleHub::Topic& t, std::int64_t t_ns, std::span<const double> values) {
  auto it = subs_.find(t.id);
  if (it == subs_.end()) return;
  Subscription& sub = it->second;
  const auto now = std::chrono::steady_clock::now();
  if (std::chrono::duration<double>(now - sub.last).count() < sub.min_interval_s) {
    sub.pending_t = t_ns;
    sub.pending.assign(values.begin(), values.end());
    return;
  }
  sub.last = now;
  sub.pending_t = -1;
  if (sub.rows.size() > 256 * 1024) return;  // a flush is late: keep the memory bounded
  if (!sub.rows.empty()) sub.rows += ',';
  append_row(sub.rows, t_ns, values);
}

void WsSession::flush_samples(const SampleHub& hub, bool held) {
  const auto now = std::chrono::steady_clock::now();
  for (auto& [id, sub] : subs_) {
    // the newest sample held back, once its interval has passed (or at once: `held`)
    if (sub.pending_t >= 0 && (held || std::chrono::duration<double>(now - sub.last).count() >= sub.min_interval_s)) {
      if (!sub.rows.empty()) sub.rows += ',';
      append_row(sub.rows, sub.pending_t, sub.pending);
      sub.pending_t = -1;
      sub.last = now;
    }
    if (sub.rows.empty()) continue;
    const SampleHub::Topic* t = hub.topic(id);
    std::string msg = "{\"type\":\"samples\",\"topic\":" + std::to_string(id) + ",\"name\":";
    json::append_string(msg, t ? t->name : "");
    msg += ",\"rows\":[" + sub.rows + "]}";
    sub.rows.clear();
    send(std::move(msg), false, true);
    if (!open_) return;
  }
}

// ------------------------------------------------------------------------------------------ the server's parts

bool ServerImpl::start(const Address& at, std::string* error) {
  if (at.kind != Transport::Tcp) {
    if (error) *error = "the monitor listens on TCP only, not " + at.str();
    return false;
  }
  beast::error_code ec;
  const auto ip = boost::asio::ip::make_address(at.host, ec);
  if (ec) {
    if (error) *error = "bad address '" + at.host + "': " + ec.message();
    return false;
  }
  const tcp::endpoint ep(ip, at.port);
  acceptor_.open(ep.protocol(), ec);
  if (!ec) acceptor_.set_option(tcp::acceptor::reuse_address(true), ec);
  if (!ec) acceptor_.bind(ep, ec);
  if (!ec) acceptor_.listen(boost::asio::socket_base::max_listen_connections, ec);
  if (ec) {
    if (error) *error = "cannot listen on " + at.str() + ": " + ec.message();
    return false;
  }
  bound_ = at;
  bound_.port = acceptor_.local_endpoint().port();
  token_ = random_token();
  tokens_.insert(token_);
  hub_.add_observer(this);
  accept();
  return true;
}

void ServerImpl::accept() {
  acceptor_.async_accept([w = std::weak_ptr<ServerImpl>(std::static_pointer_cast<ServerImpl>(shared_from_this()))](
                             beast::error_code ec, tcp::socket socket) {
    auto self = w.lock();
    if (!self || self->closed_) return;
    if (!ec) {
      beast::error_code pe;
      const auto ep = socket.remote_endpoint(pe);
      const std::string peer = pe ? "?" : ep.address().to_string() + ":" + std::to_string(ep.port());
      self->open_sockets_++;
      auto h = std::make_shared<HttpSession>(std::move(socket), w, peer);
      self->add_pending(h);
      h->read();
      self->accept();
      return;
    }
    // descriptors or memory ran out: try again a little later instead of spinning
    auto t = std::make_shared<boost::asio::steady_timer>(self->io_, std::chrono::milliseconds(100));
    t->async_wait([t, w](beast::error_code) {
      if (auto s = w.lock(); s && !s->closed_) s->accept();
    });
  });
}

// A new socket joins the pending pool; when it is full, the oldest pending socket is closed first.
void ServerImpl::add_pending(const std::shared_ptr<HttpSession>& h) {
  std::erase_if(pending_, [](const std::weak_ptr<HttpSession>& w) {
    const auto p = w.lock();
    return !p || p->authenticated();
  });
  while (!pending_.empty() && pending_.size() >= limits_.max_unauthenticated) {
    if (auto p = pending_.front().lock()) p->evict();
    pending_.pop_front();
    stats_.evicted++;
  }
  pending_.push_back(h);
}

bool ServerImpl::authorized(const http::request<http::string_body>& req) const {
  std::string given = query_value(sv(req.target()), "token");
  if (given.empty()) {
    const std::string_view h = sv(req[http::field::authorization]);
    if (h.starts_with("Bearer ")) given = std::string(h.substr(7));
  }
  if (given.empty()) return false;
  bool ok = false;
  for (const auto& t : tokens_) ok = auth::equal_mac(t, given) || ok;  // every token compared: constant time
  return ok;
}

http::response<http::string_body> ServerImpl::answer(const http::request<http::string_body>& req) {
  stats_.http_requests++;
  auto reply = [&req](http::status st, const std::string& type, std::string body) {
    http::response<http::string_body> res{st, req.version()};
    res.set(http::field::server, "dca");
    res.set(http::field::content_type, type);
    res.set(http::field::cache_control, "no-store");
    res.keep_alive(req.keep_alive());
    res.body() = std::move(body);
    res.prepare_payload();
    return res;
  };
  if (req.method() != http::verb::get && req.method() != http::verb::head) {
    stats_.bad_requests++;
    return reply(http::status::method_not_allowed, "text/plain", "GET only\n");
  }
  auto it = pages_.find(std::string(path_of(sv(req.target()))));
  if (it == pages_.end()) return reply(http::status::not_found, "text/plain", "not found\n");
  if (!it->second.second && !authorized(req)) {
    stats_.refused++;
    return reply(http::status::unauthorized, "text/plain", "a token is needed (?token=...)\n");
  }
  return reply(http::status::ok, it->second.first.content_type, it->second.first.body);
}

std::optional<http::response<http::string_body>> ServerImpl::refusal(const http::request<http::string_body>& req,
                                                                    std::string* chosen) {
  // the subprotocol: the first one the client offers that has a handler; none offered: the default one
  const std::string offered(req[http::field::sec_websocket_protocol]);
  std::string_view rest = offered;
  while (!rest.empty() && chosen->empty()) {
    const auto comma = rest.find(',');
    std::string_view p = rest.substr(0, comma);
    while (!p.empty() && p.front() == ' ') p.remove_prefix(1);
    while (!p.empty() && p.back() == ' ') p.remove_suffix(1);
    if (protocols_.count(std::string(p))) *chosen = p;
    rest = comma == std::string_view::npos ? std::string_view() : rest.substr(comma + 1);
  }
  if (offered.empty()) *chosen = default_protocol_;
  auto refuse = [&req](http::status st, std::string body) {
    http::response<http::string_body> res{st, req.version()};
    res.set(http::field::server, "dca");
    res.set(http::field::content_type, "text/plain");
    res.keep_alive(false);
    res.body() = std::move(body);
    res.prepare_payload();
    return res;
  };
  if (!authorized(req)) {
    stats_.refused++;
    return refuse(http::status::unauthorized, "a token is needed (?token=...)\n");
  }
  if (chosen->empty()) {
    stats_.bad_requests++;
    return refuse(http::status::bad_request, "no such subprotocol: " + offered + "\n");
  }
  return std::nullopt;
}

void ServerImpl::upgrade(tcp::socket socket, http::request<http::string_body> req, const std::string& chosen,
                         const std::string& peer) {
  stats_.websockets++;
  const std::uint64_t id = next_id_++;
  auto w = std::weak_ptr<ServerImpl>(std::static_pointer_cast<ServerImpl>(shared_from_this()));
  auto session = std::make_shared<WsSession>(std::move(socket), w, id, chosen, protocols_[chosen], limits_, peer);
  sessions_[id] = session;
  session->start(std::move(req));
}

std::map<std::uint64_t, Connection::Ptr> ServerImpl::connections() const {
  std::map<std::uint64_t, Connection::Ptr> out;
  for (const auto& [id, w] : sessions_)
    if (auto s = w.lock(); s && s->is_open()) out[id] = s;
  return out;
}

void ServerImpl::on_sample(const SampleHub::Topic& t, std::int64_t t_ns, std::span<const double> values) {
  for (const auto& [id, w] : sessions_)
    if (auto s = w.lock()) s->on_sample(t, t_ns, values);
}

void ServerImpl::arm_flush() {
  flush_armed_ = true;
  flush_.expires_after(limits_.sample_flush);
  flush_.async_wait([w = std::weak_ptr<ServerImpl>(std::static_pointer_cast<ServerImpl>(shared_from_this()))](
                        beast::error_code ec) {
    auto self = w.lock();
    if (!self || ec || self->closed_) return;
    self->flush_armed_ = false;
    const auto sessions = self->sessions_;  // a send may close a session
    for (const auto& [id, ws] : sessions)
      if (auto s = ws.lock()) s->flush_samples(self->hub_);
    if (!self->sessions_.empty()) self->arm_flush();
  });
}

void ServerImpl::flush_samples() {
  if (closed_) return;
  const auto sessions = sessions_;  // a send may close a session
  for (const auto& [id, ws] : sessions)
    if (auto s = ws.lock()) s->flush_samples(hub_, true);
}

void ServerImpl::close() {
  if (closed_) return;
  closed_ = true;
  beast::error_code ignored;
  acceptor_.close(ignored);
  flush_.cancel();
  for (auto& [id, c] : connections()) c->close("the server closed");
}

}  // namespace

Server::Ptr Server::listen(boost::asio::io_context& io, const Address& at, Limits limits, std::string* error) {
  auto s = std::make_shared<ServerImpl>(io, limits);
  if (!s->start(at, error)) return nullptr;
  return s;
}

}  // namespace dca::web
