#include "host/net/channel.h"

#include <sys/socket.h>
#include <unistd.h>

#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <cstdio>

namespace dca {
namespace asio = boost::asio;
using generic_stream = asio::generic::stream_protocol;
using boost::system::error_code;

// ---------------------------------------------------------------------------------------------------- Channel

Channel::Channel(asio::io_context& io, ChannelOptions options, std::string peer)
    : io_(io), options_(std::move(options)), framed_(FramedSocket::Socket(io), *this), deadline_(io), peer_(std::move(peer)) {}

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
  // Weak: the channel keeps this callback until its handshake ends, and the pending connect or read keeps the
  // channel; a strong reference here would be a cycle that a loop stopped mid-handshake never frees.
  auto finish = [w = std::weak_ptr<Channel>(ch), done = std::move(done)](const std::string& err) {
    auto c = w.lock();
    if (err.empty() && c) {
      done(c, "");
    } else {
      done(nullptr, err.empty() ? "the channel was destroyed" : err);
    }
  };
  ch->handshake_done_ = finish;
  error_code ec;
  ch->socket().open(ep->protocol(), ec);
  if (ec) {
    ch->fail_handshake("cannot open a socket to " + to.str() + ": " + ec.message());
    return;
  }
  ch->socket().async_connect(*ep, [ch, finish](const error_code& cec) {
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
  if (socket().local_endpoint(ec).protocol().family() != AF_UNIX) socket().set_option(asio::ip::tcp::no_delay(true), ec);
  if (role == auth::Handshake::Role::kServer) {
    deadline_.expires_after(options_.handshake_timeout);
    deadline_.async_wait([w = weak_from_this()](const error_code& tec) {
      if (tec) return;
      if (auto c = w.lock(); c && c->state_ == State::kHandshake)
        c->fail_handshake("handshake with " + c->peer_ + " timed out");
    });
  }
  handshake_ = std::make_unique<auth::Handshake>(role, options_.key);
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

void Channel::read() { framed_.read(shared_from_this()); }

void Channel::on_read(const error_code& ec, std::size_t n) {
  if (state_ == State::kClosed || state_ == State::kClosing) return;
  if (ec) {
    const std::string why = ec == asio::error::eof ? "connection closed by the peer" : "connection lost: " + ec.message();
    if (state_ == State::kHandshake) {
      fail_handshake(why + " during the handshake with " + peer_);
    } else {
      close(why + (framed_.unread().empty() ? "" : " (in the middle of a frame)"));
    }
    return;
  }
  stats_.bytes_in += n;
  on_frames();
}

// Handles every whole frame read, then reads on (unless the channel closed meanwhile).
void Channel::on_frames() {
  auto self = shared_from_this();  // a handler may drop the last other reference
  while (state_ == State::kHandshake || state_ == State::kOpen) {
    // until the peer has proved the key, a frame is small: the handshake's messages are ~100 bytes
    const std::size_t limit = state_ == State::kHandshake ? std::min(options_.max_frame, kHandshakeMaxFrame)
                                                          : options_.max_frame;
    auto d = wire::decode_frame(framed_.unread(), limit);
    if (d.status == wire::Decoded::Status::kNeedMore) return read();
    if (d.status == wire::Decoded::Status::kError) {
      const std::string reason = "malformed frame from " + peer_ + ": " + d.error;
      if (state_ != State::kHandshake) return close(reason, true);
      enqueue(wire::Message{"error", 0, wire::Value::map().set("reason", reason)});
      auto done = std::move(handshake_done_);
      handshake_done_ = nullptr;
      state_ = State::kOpen;
      close(reason, false);
      if (done) done(reason);
      return;
    }
    framed_.consume(d.consumed);
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
  if (!wire::encode(m, framed_.queue(), &error)) {
    std::fprintf(stderr, "dca: cannot send '%s' to %s: %s\n", m.type.c_str(), peer_.c_str(), error.c_str());
    return;
  }
  ++stats_.frames_out;
}

void Channel::flush() {
  if (state_ == State::kClosed) return;
  framed_.flush(shared_from_this());
}

void Channel::on_written(const error_code& ec, std::size_t n) {
  stats_.bytes_out += n;
  if (state_ == State::kClosed) return;
  if (ec) {
    if (state_ == State::kClosing) {
      finish_close();
    } else if (state_ == State::kHandshake) {
      fail_handshake("connection lost during the handshake with " + peer_ + ": " + ec.message());
    } else {
      close("connection lost: " + ec.message());
    }
    return;
  }
  if (framed_.queued() == 0 && state_ == State::kClosing) finish_close();
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
  if (!framed_.idle()) {
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
  if (state_ == State::kClosed && !socket().is_open()) return;
  state_ = State::kClosed;
  error_code ec;
  deadline_.cancel(ec);
  framed_.close();
}

// --------------------------------------------------------------------------------------------------- Listener

Listener::Listener(asio::io_context& io, ChannelOptions options)
    : io_(io), options_(std::move(options)), acceptor_(io), backoff_(io) {}

Listener::~Listener() {
  error_code ec;
  acceptor_.close(ec);
  if (address_.kind == Transport::Unix && !closed_) ::unlink(address_.path.c_str());
}

Listener::Ptr Listener::listen(asio::io_context& io, const Address& at, ChannelOptions options, ChannelFn on_channel,
                               std::string* error, RefusedFn on_refused) {
  auto l = std::make_shared<Listener>(io, std::move(options));
  l->on_channel_ = std::move(on_channel);
  l->on_refused_ = std::move(on_refused);
  if (!listen_at(l->acceptor_, at, &l->address_, error)) return nullptr;
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
      // EMFILE and friends: back off, say so at a bounded rate, accept again
      self->backoff_.failed(ec, self->address_.str(), self->on_refused_, [w = std::weak_ptr<Listener>(self)] {
        if (auto l = w.lock(); l && !l->closed_) l->accept();
      });
      return;
    }
    self->backoff_.succeeded();
    error_code rec;
    const auto remote = sock->remote_endpoint(rec);
    std::string peer = rec ? std::string("(unknown peer)") : endpoint_str(remote);
    if (self->address_.kind == Transport::Unix) peer = "unix:" + self->address_.path + " (peer)";
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
        l->refusals_.say("refused a connection on " + l->address_.str() + ": " + err, l->on_refused_);
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
  backoff_.cancel();
  error_code ec;
  acceptor_.close(ec);
  if (address_.kind == Transport::Unix) ::unlink(address_.path.c_str());
  on_channel_ = nullptr;
  on_refused_ = nullptr;
}

}  // namespace dca
