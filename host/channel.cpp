#include "host/channel.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/local/stream_protocol.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/write.hpp>
#include <charconv>
#include <cstdio>
#include <cstring>

namespace dca {
namespace asio = boost::asio;
using generic_stream = asio::generic::stream_protocol;
using boost::system::error_code;

namespace {

constexpr std::size_t kReadChunk = 64 * 1024;

std::string endpoint_str(const generic_stream::endpoint& ep) {
  const auto* sa = ep.data();
  if (ep.size() >= sizeof(sa_family_t) && sa->sa_family == AF_INET && ep.size() >= sizeof(sockaddr_in)) {
    sockaddr_in in{};
    std::memcpy(&in, sa, sizeof in);
    char buf[INET_ADDRSTRLEN] = {};
    ::inet_ntop(AF_INET, &in.sin_addr, buf, sizeof buf);
    return std::string(buf) + ":" + std::to_string(ntohs(in.sin_port));
  }
  if (ep.size() >= sizeof(sa_family_t) && sa->sa_family == AF_INET6 && ep.size() >= sizeof(sockaddr_in6)) {
    sockaddr_in6 in{};
    std::memcpy(&in, sa, sizeof in);
    char buf[INET6_ADDRSTRLEN] = {};
    ::inet_ntop(AF_INET6, &in.sin6_addr, buf, sizeof buf);
    return "[" + std::string(buf) + "]:" + std::to_string(ntohs(in.sin6_port));
  }
  return "unix:(peer)";
}

std::optional<generic_stream::endpoint> to_endpoint(const Address& a, std::string* error) {
  if (a.kind == Address::Kind::kUnix) {
    if (a.path.size() >= sizeof(sockaddr_un::sun_path)) {
      if (error != nullptr) *error = "socket path too long: " + a.path;
      return std::nullopt;
    }
    return generic_stream::endpoint(asio::local::stream_protocol::endpoint(a.path));
  }
  error_code ec;
  const auto ip = asio::ip::make_address(a.host, ec);
  if (ec) {
    if (error != nullptr) *error = "bad IP address '" + a.host + "'";
    return std::nullopt;
  }
  return generic_stream::endpoint(asio::ip::tcp::endpoint(ip, a.port));
}

}  // namespace

// ---------------------------------------------------------------------------------------------------- Address

std::optional<Address> Address::parse(std::string_view text, std::string* error) {
  const auto bad = [&](const char* why) -> std::optional<Address> {
    if (error != nullptr) *error = "bad address '" + std::string(text) + "': " + why;
    return std::nullopt;
  };
  Address a;
  std::string_view t = text;
  if (t.substr(0, 5) == "unix:" || (!t.empty() && t[0] == '/')) {
    a.kind = Kind::kUnix;
    a.path = std::string(t[0] == '/' ? t : t.substr(5));
    if (a.path.empty()) return bad("empty socket path");
    if (a.path.size() >= sizeof(sockaddr_un::sun_path)) return bad("socket path too long");
    return a;
  }
  if (t.substr(0, 4) == "tcp:") t = t.substr(4);
  std::string_view host, port;
  if (!t.empty() && t[0] == '[') {
    const auto close = t.find(']');
    if (close == std::string_view::npos || close + 1 >= t.size() || t[close + 1] != ':')
      return bad("expected [IPv6]:PORT");
    host = t.substr(1, close - 1);
    port = t.substr(close + 2);
  } else {
    const auto colon = t.rfind(':');
    if (colon == std::string_view::npos) return bad("expected HOST:PORT, unix:PATH or /PATH");
    host = t.substr(0, colon);
    port = t.substr(colon + 1);
  }
  unsigned p = 0;
  const auto [end, ec] = std::from_chars(port.data(), port.data() + port.size(), p);
  if (ec != std::errc() || end != port.data() + port.size() || p > 65535 || port.empty())
    return bad("the port is not a number from 0 to 65535");
  a.port = static_cast<std::uint16_t>(p);
  a.host = host == "localhost" ? "127.0.0.1" : std::string(host);
  error_code ip_ec;
  asio::ip::make_address(a.host, ip_ec);
  if (ip_ec) return bad("the host is not a numeric IP address (or localhost)");
  return a;
}

std::string Address::str() const {
  if (kind == Kind::kUnix) return "unix:" + path;
  if (host.find(':') != std::string::npos) return "[" + host + "]:" + std::to_string(port);
  return host + ":" + std::to_string(port);
}

// ---------------------------------------------------------------------------------------------------- Channel

Channel::Channel(asio::io_context& io, ChannelOptions options, std::string peer)
    : io_(io), options_(std::move(options)), socket_(io), deadline_(io), peer_(std::move(peer)) {}

Channel::~Channel() = default;

void Channel::connect(asio::io_context& io, const Address& to, ChannelOptions options, ConnectFn done) {
  std::string error;
  const auto ep = to_endpoint(to, &error);
  auto ch = std::make_shared<Channel>(io, std::move(options), to.str());
  if (!ep) {
    asio::post(io, [done = std::move(done), error] { done(nullptr, error); });
    return;
  }
  // One deadline covers connect and handshake.
  ch->deadline_.expires_after(ch->options_.handshake_timeout);
  ch->deadline_.async_wait([w = std::weak_ptr<Channel>(ch)](const error_code& ec) {
    if (ec) return;
    if (auto c = w.lock(); c && c->state_ == State::kHandshake) c->fail_handshake("timed out connecting to " + c->peer_);
  });
  auto finish = [ch, done = std::move(done)](const std::string& err) {
    if (err.empty()) {
      done(ch, "");
    } else {
      done(nullptr, err);
    }
  };
  ch->handshake_done_ = finish;
  error_code ec;
  ch->socket_.open(ep->protocol(), ec);
  if (ec) {
    ch->fail_handshake("cannot open a socket to " + to.str() + ": " + ec.message());
    return;
  }
  ch->socket_.async_connect(*ep, [ch, finish](const error_code& cec) {
    if (ch->state_ != State::kHandshake) return;  // timed out meanwhile
    if (cec) {
      ch->fail_handshake("cannot connect to " + ch->peer_ + ": " + cec.message());
      return;
    }
    ch->start(auth::Handshake::Role::kClient, finish);
  });
}

void Channel::start(auth::Handshake::Role role, std::function<void(const std::string&)> done) {
  handshake_done_ = std::move(done);
  error_code ec;
  if (socket_.local_endpoint(ec).protocol().family() != AF_UNIX) socket_.set_option(asio::ip::tcp::no_delay(true), ec);
  if (role == auth::Handshake::Role::kServer) {
    deadline_.expires_after(options_.handshake_timeout);
    deadline_.async_wait([w = weak_from_this()](const error_code& tec) {
      if (tec) return;
      if (auto c = w.lock(); c && c->state_ == State::kHandshake)
        c->fail_handshake("handshake with " + c->peer_ + " timed out");
    });
  }
  handshake_ = std::make_unique<auth::Handshake>(role, options_.key);
  in_.resize(kReadChunk);
  read();
  handshake_step(handshake_->start());
}

void Channel::fail_handshake(const std::string& reason) {
  if (state_ != State::kHandshake) return;
  auto done = std::move(handshake_done_);
  handshake_done_ = nullptr;
  state_ = State::kOpen;  // so that close() shuts the socket (flushing any error notice for the peer)
  close(reason, false);
  if (done) done(reason);
}

void Channel::handshake_step(auth::Handshake::Step step) {
  for (const auto& m : step.out) enqueue(m);
  if (step.state == auth::Handshake::State::kRunning) {
    flush();
    return;
  }
  if (step.state == auth::Handshake::State::kFailed) {
    const std::string reason = handshake_->reason() + " (peer " + peer_ + ")";
    auto done = std::move(handshake_done_);
    handshake_done_ = nullptr;
    // The error message for the peer is queued: flush it, then close.
    state_ = State::kOpen;  // let close() take the flushing path
    close(reason, false);
    if (done) done(reason);
    return;
  }
  // Done: the channel is open.
  state_ = State::kOpen;
  error_code ec;
  deadline_.cancel(ec);
  flush();
  auto done = std::move(handshake_done_);
  handshake_done_ = nullptr;
  if (done) done("");
}

void Channel::read() {
  if (in_end_ == in_.size()) {
    // Compact, then grow if a frame needs more room.
    if (in_begin_ > 0) {
      std::memmove(in_.data(), in_.data() + in_begin_, in_end_ - in_begin_);
      in_end_ -= in_begin_;
      in_begin_ = 0;
    }
    if (in_end_ == in_.size()) in_.resize(in_.size() * 2);
  }
  socket_.async_read_some(asio::buffer(in_.data() + in_end_, in_.size() - in_end_),
                          [self = shared_from_this()](const error_code& ec, std::size_t n) {
                            if (self->state_ == State::kClosed || self->state_ == State::kClosing) return;
                            if (ec) {
                              const std::string why = ec == asio::error::eof ? "connection closed by the peer"
                                                                              : "connection lost: " + ec.message();
                              if (self->state_ == State::kHandshake) {
                                self->fail_handshake(why + " during the handshake with " + self->peer_);
                              } else {
                                self->close(why + (self->in_end_ > self->in_begin_ ? " (in the middle of a frame)" : ""));
                              }
                              return;
                            }
                            self->on_read(n);
                          });
}

void Channel::on_read(std::size_t n) {
  stats_.bytes_in += n;
  in_end_ += n;
  auto self = shared_from_this();  // a handler may drop the last other reference
  while (state_ == State::kHandshake || state_ == State::kOpen) {
    auto d = wire::decode_frame(std::string_view(in_.data() + in_begin_, in_end_ - in_begin_), options_.max_frame);
    if (d.status == wire::Decoded::Status::kNeedMore) {
      // Make room for the whole frame when its length is known.
      if (in_end_ - in_begin_ >= wire::kHeaderSize) {
        const auto* p = reinterpret_cast<const unsigned char*>(in_.data() + in_begin_);
        const std::size_t need = wire::kHeaderSize + ((std::size_t{p[0]} << 24) | (std::size_t{p[1]} << 16) |
                                                      (std::size_t{p[2]} << 8) | std::size_t{p[3]});
        if (need > in_.size() - in_begin_) {
          std::memmove(in_.data(), in_.data() + in_begin_, in_end_ - in_begin_);
          in_end_ -= in_begin_;
          in_begin_ = 0;
          if (need > in_.size()) in_.resize(need);
        }
      }
      if (in_begin_ == in_end_) in_begin_ = in_end_ = 0;
      read();
      return;
    }
    if (d.status == wire::Decoded::Status::kError) {
      const std::string reason = "malformed frame from " + peer_ + ": " + d.error;
      if (state_ == State::kHandshake) {
        enqueue(wire::Message{"error", 0, wire::Value::map().set("reason", reason)});
        auto done = std::move(handshake_done_);
        handshake_done_ = nullptr;
        state_ = State::kOpen;
        close(reason, false);
        if (done) done(reason);
      } else {
        close(reason, true);
      }
      return;
    }
    in_begin_ += d.consumed;
    ++stats_.frames_in;
    if (state_ == State::kHandshake) {
      handshake_step(handshake_->on_message(d.message));
    } else if (!dispatch(d.message)) {
      return;
    }
  }
}

bool Channel::dispatch(wire::Message& m) {
  if (m.id != 0 && (m.type == "ok" || m.type == "error")) {
    auto it = pending_.find(m.id);
    if (it == pending_.end()) {
      ++stats_.unmatched_replies;
      return true;
    }
    Pending p = std::move(it->second);
    pending_.erase(it);
    error_code ec;
    p.timer->cancel(ec);
    Response r;
    if (m.type == "error") {
      r.error = m.payload["reason"].as_string();
      if (r.error.empty()) r.error = "error reply without a reason";
    }
    r.message = std::move(m);
    p.done(std::move(r));
    return state_ == State::kOpen;
  }
  if (m.id == 0 && m.type == "error") {
    const std::string why = m.payload["reason"].as_string();
    close("closed by the peer " + peer_ + ": " + (why.empty() ? std::string("no reason given") : why));
    return false;
  }
  if (!on_message_) {
    ++stats_.unhandled;
    if (m.id != 0) reply_error(m, "no handler for '" + m.type + "' on this channel");
    return true;
  }
  on_message_(m);
  return state_ == State::kOpen;
}

void Channel::enqueue(const wire::Message& m) {
  std::string error;
  if (!wire::encode(m, out_, &error)) {
    std::fprintf(stderr, "dca: cannot send '%s' to %s: %s\n", m.type.c_str(), peer_.c_str(), error.c_str());
    return;
  }
  ++stats_.frames_out;
}

void Channel::flush() {
  if (write_in_flight_ || out_.empty() || state_ == State::kClosed) return;
  writing_.swap(out_);
  out_.clear();
  write_in_flight_ = true;
  asio::async_write(socket_, asio::buffer(writing_), [self = shared_from_this()](const error_code& ec, std::size_t n) {
    self->write_in_flight_ = false;
    self->stats_.bytes_out += n;
    self->writing_.clear();
    if (self->state_ == State::kClosed) return;
    if (ec) {
      if (self->state_ == State::kClosing) {
        self->finish_close();
      } else if (self->state_ == State::kHandshake) {
        self->fail_handshake("connection lost during the handshake with " + self->peer_ + ": " + ec.message());
      } else {
        self->close("connection lost: " + ec.message());
      }
      return;
    }
    if (!self->out_.empty()) {
      self->flush();
    } else if (self->state_ == State::kClosing) {
      self->finish_close();
    }
  });
}

bool Channel::send(wire::Message m) {
  if (state_ != State::kOpen) return false;
  enqueue(m);
  flush();
  return true;
}

std::uint64_t Channel::request(wire::Message m, std::chrono::milliseconds timeout, ResponseFn done) {
  if (state_ != State::kOpen) {
    std::string why = "channel to " + peer_ + " is closed" + (close_reason_.empty() ? "" : ": " + close_reason_);
    asio::post(io_, [done = std::move(done), why = std::move(why)] {
      Response r;
      r.error = why;
      done(std::move(r));
    });
    return 0;
  }
  const std::uint64_t id = next_id_++;
  m.id = id;
  Pending p{std::move(done), std::make_unique<asio::steady_timer>(io_)};
  p.timer->expires_after(timeout);
  p.timer->async_wait([w = weak_from_this(), id, timeout, type = m.type](const error_code& ec) {
    if (ec) return;
    auto self = w.lock();
    if (!self) return;
    auto it = self->pending_.find(id);
    if (it == self->pending_.end()) return;
    Pending pend = std::move(it->second);
    self->pending_.erase(it);
    Response r;
    r.error = "timeout: no reply to '" + type + "' from " + self->peer_ + " within " +
              std::to_string(timeout.count()) + " ms";
    pend.done(std::move(r));
  });
  pending_.emplace(id, std::move(p));
  enqueue(m);
  flush();
  return id;
}

bool Channel::reply(const wire::Message& to, wire::Value payload) { return send(wire::make_reply(to, std::move(payload))); }

bool Channel::reply_error(const wire::Message& to, std::string_view reason) { return send(wire::make_error(to, reason)); }

void Channel::on_close(CloseFn fn) {
  if (state_ == State::kClosed || state_ == State::kClosing) {
    asio::post(io_, [fn = std::move(fn), why = close_reason_] { fn(why); });
    return;
  }
  on_close_ = std::move(fn);
}

void Channel::close(const std::string& reason, bool tell_peer) {
  if (state_ == State::kClosed || state_ == State::kClosing) return;
  if (state_ == State::kHandshake) {
    fail_handshake(reason);
    return;
  }
  auto self = shared_from_this();
  close_reason_ = reason;
  if (tell_peer) enqueue(wire::Message{"error", 0, wire::Value::map().set("reason", reason)});
  error_code ec;
  deadline_.cancel(ec);
  if (!out_.empty() || write_in_flight_) {
    // Flush what is queued (the handshake's or this error notice), bounded by a 1 s deadline.
    state_ = State::kClosing;
    flush();
    deadline_.expires_after(std::chrono::seconds(1));
    deadline_.async_wait([self](const error_code& tec) {
      if (!tec && self->state_ == State::kClosing) self->finish_close();
    });
  } else {
    finish_close();
  }
  // The callbacks run now; when flushing, the socket closes once the flush ends.
  auto pending = std::move(pending_);
  pending_.clear();
  for (auto& [id, p] : pending) {
    p.timer->cancel(ec);
    Response r;
    r.error = "channel to " + peer_ + " closed: " + reason;
    p.done(std::move(r));
  }
  on_message_ = nullptr;
  auto on_close = std::move(on_close_);
  on_close_ = nullptr;
  if (on_close) on_close(reason);
}

void Channel::finish_close() {
  if (state_ == State::kClosed && !socket_.is_open()) return;
  state_ = State::kClosed;
  error_code ec;
  deadline_.cancel(ec);
  socket_.shutdown(asio::socket_base::shutdown_both, ec);
  socket_.close(ec);
}

// --------------------------------------------------------------------------------------------------- Listener

Listener::Listener(asio::io_context& io, ChannelOptions options)
    : io_(io), options_(std::move(options)), acceptor_(io) {}

Listener::~Listener() {
  error_code ec;
  acceptor_.close(ec);
  if (address_.kind == Address::Kind::kUnix && !closed_) ::unlink(address_.path.c_str());
}

Listener::Ptr Listener::listen(asio::io_context& io, const Address& at, ChannelOptions options, ChannelFn on_channel,
                               std::string* error, RefusedFn on_refused) {
  auto l = std::make_shared<Listener>(io, std::move(options));
  l->on_channel_ = std::move(on_channel);
  l->on_refused_ = std::move(on_refused);
  const auto ep = to_endpoint(at, error);
  if (!ep) return nullptr;
  const auto fail = [&](const char* what, const error_code& ec) -> Ptr {
    if (error != nullptr) *error = std::string("cannot listen on ") + at.str() + ": " + what + ": " + ec.message();
    return nullptr;
  };
  if (at.kind == Address::Kind::kUnix) {
    struct stat st {};
    if (::lstat(at.path.c_str(), &st) == 0 && S_ISSOCK(st.st_mode)) ::unlink(at.path.c_str());
  }
  error_code ec;
  l->acceptor_.open(ep->protocol(), ec);
  if (ec) return fail("open", ec);
  if (at.kind == Address::Kind::kTcp) l->acceptor_.set_option(asio::socket_base::reuse_address(true), ec);
  l->acceptor_.bind(*ep, ec);
  if (ec) return fail("bind", ec);
  l->acceptor_.listen(asio::socket_base::max_listen_connections, ec);
  if (ec) return fail("listen", ec);
  l->address_ = at;
  if (at.kind == Address::Kind::kTcp) {
    const auto local = l->acceptor_.local_endpoint(ec);
    if (!ec) {
      if (auto parsed = Address::parse(endpoint_str(local))) l->address_ = *parsed;
    }
  }
  l->accept();
  return l;
}

void Listener::accept() {
  auto self = shared_from_this();
  auto sock = std::make_shared<generic_stream::socket>(io_);
  acceptor_.async_accept(*sock, [self, sock](const error_code& ec) {
    if (self->closed_ || !self->acceptor_.is_open()) return;
    if (ec) {
      if (ec == asio::error::operation_aborted) return;
      // EMFILE and friends: report and keep accepting.
      if (self->on_refused_) self->on_refused_("accept failed on " + self->address_.str() + ": " + ec.message());
      self->accept();
      return;
    }
    error_code rec;
    const auto remote = sock->remote_endpoint(rec);
    std::string peer = rec ? std::string("(unknown peer)") : endpoint_str(remote);
    if (self->address_.kind == Address::Kind::kUnix) peer = "unix:" + self->address_.path + " (peer)";
    auto ch = std::make_shared<Channel>(self->io_, self->options_, peer);
    ch->socket() = std::move(*sock);
    std::weak_ptr<Listener> w = self;
    ch->start(auth::Handshake::Role::kServer, [w, ch](const std::string& err) {
      auto l = w.lock();
      if (!l) {
        if (err.empty()) ch->close("the listener closed");
        return;
      }
      if (!err.empty()) {
        ++l->refused_;
        if (l->on_refused_) l->on_refused_("refused a connection on " + l->address_.str() + ": " + err);
        return;
      }
      if (l->on_channel_) l->on_channel_(ch);
    });
    self->accept();
  });
}

void Listener::close() {
  if (closed_) return;
  closed_ = true;
  error_code ec;
  acceptor_.close(ec);
  if (address_.kind == Address::Kind::kUnix) ::unlink(address_.path.c_str());
  on_channel_ = nullptr;
  on_refused_ = nullptr;
}

}  // namespace dca
