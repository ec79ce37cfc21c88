#pragma once
// host/net: sockets on the io_context (Asio). Never Beast, never host/web.
// The control plane's channel: an authenticated connection carrying wire messages (host/codec/wire) over TCP or a
// Unix socket, on the process's one io_context (host/loop). Everything here runs on that io_context's thread:
// call these functions from it (or before it runs), never from another thread.
//
//   dca::Loop loop;
//   dca::ChannelOptions opts{key};
//   dca::Channel::connect(loop.io(), *dca::Address::parse("127.0.0.1:4000"), opts,
//       [](dca::Channel::Ptr ch, const std::string& error) {
//         if (!ch) { report(error); return; }
//         ch->on_close([](const std::string& reason) { ... });
//         ch->request({"lookup", 0, Value::map().set("name", "arm")}, 2s, [](dca::Response r) { ... });
//       });
//
// Guarantees: every wait has a deadline (connect + handshake: ChannelOptions::handshake_timeout; each request:
// its timeout); a request's callback runs exactly once (the reply, or an error after the timeout or when the
// channel closes); on_close runs exactly once per channel with the reason; a malformed or oversize frame
// closes only that channel (the peer is told why in an `error` event first). Errors are values: no function
// here throws for a network or protocol error.
//
// Frames travel on a FramedSocket (host/net/framed_socket), which also parses the Address of either end.
//
// Reserved message types: "hello", "challenge", "proof", "welcome" (the handshake, host/net/auth), "ok" and
// "error" with a request's id (replies), and "error" with id 0 (the notice a side sends before it closes:
// the receiver closes with "closed by the peer: <reason>").
#include "host/net/framed_socket.h"  // first: host/loop.h's Asio set-up; Address

#include <boost/asio/steady_timer.hpp>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "host/codec/wire.h"
#include "host/net/auth.h"

namespace dca {

/// The largest frame a peer may send before the handshake is done (the handshake's messages are ~100 bytes).
inline constexpr std::size_t kHandshakeMaxFrame = 4096;

/// Settings of a channel or listener.
struct ChannelOptions {
  auth::Key key;                                          ///< the cluster key; empty: every handshake fails
  std::chrono::milliseconds handshake_timeout{5000};      ///< deadline for connect + handshake
  std::size_t max_frame = wire::kDefaultMaxFrame;         ///< largest body accepted from the peer once
                                                          ///< authenticated (before: kHandshakeMaxFrame)
};

/// What a request gets back: a reply, or why there is none.
struct Response {
  wire::Message message;  ///< the reply ("ok" or "error"); type "" when none arrived
  std::string error;      ///< "" for an "ok" reply; payload.reason of an "error" reply; else timeout/close text
  bool ok() const { return error.empty(); }
  bool replied() const { return !message.type.empty(); }
};

/// Counters of one channel.
struct ChannelStats {
  std::uint64_t frames_in = 0, frames_out = 0, bytes_in = 0, bytes_out = 0;
  std::uint64_t unmatched_replies = 0;  ///< replies whose request had already timed out (or never existed)
  std::uint64_t unhandled = 0;          ///< messages that arrived with no on_message handler set
};

/// One authenticated connection. Held by shared_ptr; it stays alive while its socket is open (its pending
/// read holds it), so a dropped Ptr does not close it: call close().
class Channel : public std::enable_shared_from_this<Channel>, private FramedSocket::Owner {
 public:
  using Ptr = std::shared_ptr<Channel>;
  using MessageFn = std::function<void(const wire::Message&)>;
  using CloseFn = std::function<void(const std::string& reason)>;
  using ResponseFn = std::function<void(Response)>;
  /// Connect result: the open channel, or nullptr and why.
  using ConnectFn = std::function<void(Ptr, const std::string& error)>;

  /// Connects to `to` and runs the client side of the handshake; calls `done` once, from the loop, with the
  /// authenticated channel or with an error (refused, wrong key, unreachable, handshake timeout...).
  static void connect(boost::asio::io_context& io, const Address& to, ChannelOptions options, ConnectFn done);

  /// Sends an event or request as is (`m.id` as given). Returns false (and sends nothing) once closed.
  bool send(wire::Message m);
  /// Sends `m` as a request (a fresh id replaces m.id). `done` runs exactly once: with the reply, or with an
  /// error after `timeout` or when the channel closes. Returns the request id (0 if already closed: `done`
  /// then runs from the loop with the error).
  std::uint64_t request(wire::Message m, std::chrono::milliseconds timeout, ResponseFn done);
  /// Replies "ok" with `payload` to the request `to`.
  bool reply(const wire::Message& to, wire::Value payload = wire::Value::map());
  /// Replies "error" {reason} to the request `to`.
  bool reply_error(const wire::Message& to, std::string_view reason);

  /// Handler for every message that is not a reply to this side's request: requests (id != 0) and events.
  /// A request that arrives while no handler is set is answered with an error.
  void on_message(MessageFn fn) { on_message_ = std::move(fn); }
  /// Handler called once when the channel closes, with the reason. Set after the close: called from the loop.
  void on_close(CloseFn fn);
  /// Closes the channel: pending requests fail, on_close runs (now, with `reason`). With `tell_peer`, an
  /// `error {reason}` event is flushed to the peer first (bounded by 1 s).
  void close(const std::string& reason = "closed by this side", bool tell_peer = false);

  bool is_open() const { return state_ == State::kOpen; }
  /// The peer's address ("127.0.0.1:5555", "unix:/path" or "unix:(peer)").
  const std::string& peer() const { return peer_; }
  /// Why the channel closed ("" while open).
  const std::string& close_reason() const { return close_reason_; }
  std::size_t pending_requests() const { return pending_.size(); }
  /// Bytes queued to send and not yet handed to the socket: a slow peer's backlog.
  std::size_t queued_bytes() const { return framed_.queued(); }
  const ChannelStats& stats() const { return stats_; }
  boost::asio::io_context& io() { return io_; }

  /// Internal (used by Listener): a channel on an accepted socket, before its handshake.
  Channel(boost::asio::io_context& io, ChannelOptions options, std::string peer);
  ~Channel() override;
  Channel(const Channel&) = delete;
  Channel& operator=(const Channel&) = delete;
  /// Internal (used by Listener and connect): runs the handshake as `role` on the connected socket and calls
  /// `done(error)` once ("" when authenticated).
  void start(auth::Handshake::Role role, std::function<void(const std::string&)> done);
  boost::asio::generic::stream_protocol::socket& socket() { return framed_.socket(); }

 private:
  enum class State { kHandshake, kOpen, kClosing, kClosed };
  struct Pending {
    ResponseFn done;
    std::unique_ptr<boost::asio::steady_timer> timer;
  };

  void read();
  void on_read(const boost::system::error_code& ec, std::size_t n) override;
  void on_written(const boost::system::error_code& ec, std::size_t n) override;
  void on_frames();
  bool dispatch(wire::Message& m);  // false when the channel closed
  void handshake_step(auth::Handshake::Step step);
  void enqueue(const wire::Message& m);
  void flush();
  void finish_close();
  void fail_handshake(const std::string& reason);

  boost::asio::io_context& io_;
  ChannelOptions options_;
  FramedSocket framed_;
  boost::asio::steady_timer deadline_;
  std::string peer_;
  State state_ = State::kHandshake;
  std::unique_ptr<auth::Handshake> handshake_;
  std::function<void(const std::string&)> handshake_done_;

  std::uint64_t next_id_ = 1;
  std::unordered_map<std::uint64_t, Pending> pending_;
  MessageFn on_message_;
  CloseFn on_close_;
  std::string close_reason_;
  ChannelStats stats_;
};

/// Accepts channels on one address. Held by shared_ptr; it listens until close() (or its io_context ends).
class Listener : public std::enable_shared_from_this<Listener> {
 public:
  using Ptr = std::shared_ptr<Listener>;
  /// Called with each authenticated channel (set its handlers there).
  using ChannelFn = std::function<void(Channel::Ptr)>;
  /// Called with a message for each refused connection ("refused 127.0.0.1:5555: wrong cluster key ...").
  using RefusedFn = std::function<void(const std::string&)>;

  /// Binds and listens on `at` (TCP port 0: a free port; a Unix path: a stale socket file is replaced).
  /// Returns nullptr with *error when it cannot.
  static Ptr listen(boost::asio::io_context& io, const Address& at, ChannelOptions options, ChannelFn on_channel,
                    std::string* error, RefusedFn on_refused = {});
  /// The address it listens on (with the chosen port).
  const Address& address() const { return address_; }
  /// Stops accepting (channels already accepted stay open); removes a Unix socket file.
  void close();
  /// Connections refused so far (failed handshakes, timeouts).
  std::uint64_t refused() const { return refused_; }

  Listener(boost::asio::io_context& io, ChannelOptions options);
  ~Listener();

 private:
  void accept();
  boost::asio::io_context& io_;
  ChannelOptions options_;
  StreamAcceptor acceptor_;
  Address address_;
  ChannelFn on_channel_;
  RefusedFn on_refused_;
  std::uint64_t refused_ = 0;
  bool closed_ = false;
  AcceptBackoff backoff_;
  RateLimitedLog refusals_;
};

}  // namespace dca
