#pragma once
// host/web: HTTP/WebSocket, the only users of Beast. Included only by host/web, its bindings and taps.
// The web server of the monitor (`dca run --monitor`, `dca monitor`): HTTP/1.1 and WebSocket (Boost.Beast) on
// the process's one io_context. It serves public pages (the monitor's HTML and JavaScript), data that needs the
// token, and WebSocket connections, each handled by the Protocol registered for the subprotocol the client
// asked for ("dca.monitor.v1", "foxglove.websocket.v1", ...).
//
// Access. Every WebSocket and every data page needs a token: `?token=T` in the URL, or `Authorization: Bearer T`.
// The server makes one at random (16 bytes of OpenSSL's RAND_bytes, as 32 hex digits: token()); add_token()
// admits others (key_token(): the one derived from the cluster key, which a key holder can compute). Without it a WebSocket
// upgrade and a data page are answered 401 and nothing else happens; public pages load (they show nothing
// without data). Tokens are compared in constant time.
//
// Viewers and strangers apart (as OpenSSH's MaxStartups): a socket that has not yet presented the token is
// "pending". At most `max_unauthenticated` are pending: one more closes the oldest pending one (so idle sockets,
// reopened as they close, cannot keep a token holder out: each new connection gets its turn), and a pending socket
// must present the token within `auth_timeout`. A socket that presented it (an authorised request, or a
// WebSocket) leaves the pending pool for the `max_connections` reserved to token holders; one more token holder
// beyond them is answered 503.
//
// Bounds (Limits): at most `max_connections` token holders' sockets; an HTTP request's header and body, and a WebSocket
// message received, are limited in size (a bigger one closes that connection); an HTTP request must arrive
// within `request_timeout`; a WebSocket silent for `idle_timeout` is pinged, and closed when nothing comes back
// (a dead peer, or one that stopped in the middle of a frame). What the server sends to a WebSocket client is
// queued per connection: a message sent as droppable (samples, progress) is dropped and counted when the
// connection's queue holds more than `max_queue_bytes`; any message is refused and the connection closed ("too
// slow") when the queue would pass `close_queue_bytes`. So a slow or stalled client costs bounded memory and
// never stalls the loop; a client that lost messages reconnects and gets a fresh snapshot. A malformed frame
// closes its connection only.
//
// Live samples: samples() is the server's SampleHub (host/web/sample_hub.h). A connection subscribes to a topic
// (subscribe(), e.g. on a protocol message) with a rate: the server then sends it, every `sample_flush` (50 ms),
// one droppable JSON text message per topic with the samples kept since the last one, at most `rate` a second
// (a sample is kept when 1/rate seconds of wall time passed since the last kept one):
//   {"type":"samples","topic":ID,"name":"main.door.hit.Force","rows":[[t_s, v1, v2, ...], ...]}
// A protocol that needs another encoding (Foxglove's binary frames) observes samples() itself.
//
// Threading: everything runs on the io_context's one thread; call the server only from it.
#include "host/loop.h"  // first: Asio's core, with GCC 12's false positives silenced

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <string_view>

#include "host/net/framed_socket.h"  // Address
#include "host/net/auth.h"
#include "host/web/sample_hub.h"

namespace dca::web {

/// The server's bounds (see the header).
struct Limits {
  std::size_t max_connections = 64;            ///< sockets that presented the token (HTTP and WebSocket); 503 beyond
  std::size_t max_unauthenticated = 16;        ///< sockets yet to present it; one more closes the oldest of them
  std::chrono::milliseconds auth_timeout{3000};  ///< how long a socket may take to present the token
  std::size_t max_request_bytes = 16 * 1024;   ///< an HTTP request's header, and its body
  std::size_t max_message_bytes = 64 * 1024;   ///< a WebSocket message received
  std::size_t max_queue_bytes = 4 << 20;       ///< beyond it, droppable messages are dropped
  std::size_t close_queue_bytes = 16 << 20;    ///< beyond it, the connection is closed ("too slow")
  std::chrono::milliseconds request_timeout{10000};  ///< an HTTP request (and the WebSocket handshake)
  std::chrono::milliseconds sample_flush{50};         ///< how often subscribed samples are sent
  std::chrono::milliseconds idle_timeout{30000};      ///< a WebSocket silent this long is pinged, then closed
};

/// What a WebSocket connection counted.
struct ConnectionStats {
  std::uint64_t sent = 0, sent_bytes = 0, dropped = 0, received = 0;
  std::size_t queued_bytes = 0;
};

/// A WebSocket connection, as its Protocol sees it.
class Connection {
 public:
  using Ptr = std::shared_ptr<Connection>;
  virtual ~Connection() = default;
  /// Queues a message (text, or binary). A droppable one is dropped (false, counted) when the queue is over
  /// max_queue_bytes; any one closes the connection (false) past close_queue_bytes. False once closed.
  virtual bool send(std::string data, bool binary = false, bool droppable = false) = 0;
  /// Closes the connection (its protocol's on_close follows, once).
  virtual void close(const std::string& reason) = 0;
  virtual bool is_open() const = 0;
  /// Sends the samples of topic `id` (samples()) at most `rate` a second (0: stops).
  virtual void subscribe(std::uint32_t topic, double rate) = 0;
  /// A number that names the connection in this server (1, 2, ...).
  virtual std::uint64_t id() const = 0;
  /// The subprotocol it speaks.
  virtual const std::string& protocol() const = 0;
  /// The peer's address ("127.0.0.1:5555").
  virtual const std::string& peer() const = 0;
  virtual ConnectionStats stats() const = 0;
};

/// The handler of one WebSocket subprotocol. Called on the loop's thread.
class Protocol {
 public:
  virtual ~Protocol() = default;
  /// The connection is open (after the handshake).
  virtual void on_open(const Connection::Ptr& c) = 0;
  /// One whole message (at most Limits::max_message_bytes).
  virtual void on_message(const Connection::Ptr& c, std::string_view data, bool binary) = 0;
  /// The connection closed (by either side, or an error), once.
  virtual void on_close(const Connection::Ptr& c, const std::string& reason) = 0;
};

/// An answer to a GET.
struct Page {
  std::string content_type = "text/html; charset=utf-8";
  std::string body;
};

/// What the server counted.
struct ServerStats {
  std::uint64_t http_requests = 0, websockets = 0, refused = 0, bad_requests = 0, over_limit = 0;
  std::uint64_t evicted = 0;  ///< pending sockets closed to make room for a newer one
  std::size_t open = 0;       ///< open sockets
  std::size_t authenticated = 0;  ///< of them, those that presented the token
};

class Server : public std::enable_shared_from_this<Server> {
 public:
  using Ptr = std::shared_ptr<Server>;
  /// Listens at `at` (TCP; port 0 picks a free one). nullptr with *error when it cannot.
  static Ptr listen(boost::asio::io_context& io, const Address& at, Limits limits, std::string* error);
  virtual ~Server() = default;

  /// Where it listens ("127.0.0.1:PORT").
  virtual Address address() const = 0;
  /// The random token made when it started (32 hex digits).
  virtual const std::string& token() const = 0;
  /// Admits another token.
  virtual void add_token(const std::string& token) = 0;
  /// Serves `page` at `path` ("/", "/monitor.js"): to anyone when `public_page`, else with a token only.
  virtual void set_page(const std::string& path, Page page, bool public_page) = 0;
  /// Handles WebSocket connections that ask for subprotocol `name`. The first one registered is also used for
  /// clients that ask for none.
  virtual void add_protocol(const std::string& name, std::shared_ptr<Protocol> handler) = 0;
  /// The live samples its connections subscribe to.
  virtual SampleHub& samples() = 0;
  /// The open WebSocket connections by id.
  virtual std::map<std::uint64_t, Connection::Ptr> connections() const = 0;
  virtual ServerStats stats() const = 0;
  /// Queues every subscribed sample held back by a subscription's rate (the newest of each, Limits::sample_flush)
  /// for sending now: before the server closes at a run's end, a page gets each topic's last sample.
  virtual void flush_samples() = 0;
  /// Stops listening and closes every connection.
  virtual void close() = 0;
};

/// `n` random bytes as lower-case hex (OpenSSL's RAND_bytes): auth::random_token.
using auth::random_token;
/// The monitor's token of a cluster key (auth::key_token). A server given it (add_token) admits whoever holds
/// the key, without the key reaching a browser.
using auth::key_token;
/// The value of `name` in the query of `target` ("/ws?token=ab&x=1"), percent-decoded; "" when absent.
std::string query_value(std::string_view target, std::string_view name);

}  // namespace dca::web
