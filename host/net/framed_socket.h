#pragma once
// host/net: sockets on the io_context (Asio). Never Beast, never host/web.
// A length-prefixed framed stream socket, shared by the control plane's channels (host/net/channel) and the data
// plane's links (host/net/endpoint): where a socket connects or listens (Address), the read buffer that gathers
// whole frames, and the write queue. Every frame starts with a 4-byte big-endian length; what the length counts
// and what follows is the owner's format (host/codec/wire, host/codec/data_frame), parsed by the owner from unread().
//
// The owner (a FramedSocket::Owner) is told when a read or a write ends; it keeps itself alive across each
// wait by handing a shared pointer to read(), flush() and write_now(). Everything runs on the io_context's one
// thread; no function here throws.
#include "host/loop.h"  // first: Asio's core, with GCC 12's false positives silenced

#include <boost/asio/basic_socket_acceptor.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/generic/stream_protocol.hpp>
#include <cstddef>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "host/transport.h"

namespace dca {

/// Where a socket listens or connects: TCP ("127.0.0.1:4000", "[::1]:4000", "localhost:4000", or with the
/// prefix "tcp:") or a Unix socket ("unix:/run/dca.sock", or any text starting with '/').
struct Address {
  Transport kind = Transport::Tcp;  ///< Tcp or Unix (never InProcess)
  std::string host;        ///< numeric IP (TCP)
  std::uint16_t port = 0;  ///< TCP port (0 when listening: pick a free one)
  std::string path;        ///< socket path (Unix)

  /// Parses `text`; nullopt with *error ("bad address 'x': ...") when it is not an address.
  static std::optional<Address> parse(std::string_view text, std::string* error = nullptr);
  /// A Unix-socket address at `path`.
  static Address unix_socket(std::string path);
  /// "127.0.0.1:4000" or "unix:/path"; parse(str()) gives the same address.
  std::string str() const;
  bool operator==(const Address&) const = default;
};

using StreamEndpoint = boost::asio::generic::stream_protocol::endpoint;
using StreamAcceptor = boost::asio::basic_socket_acceptor<boost::asio::generic::stream_protocol>;

/// `a` as a socket endpoint; nullopt with *error when the path is too long or the host is not an IP.
std::optional<StreamEndpoint> to_endpoint(const Address& a, std::string* error);
/// "127.0.0.1:5555", "[::1]:5555", or "unix:(peer)" for a Unix socket.
std::string endpoint_str(const StreamEndpoint& ep);
/// Opens `acceptor` listening at `at` (a stale Unix socket file is replaced; TCP port 0 picks a free port) and
/// sets *bound to the address it listens on. False with *error ("cannot listen on ...") when it cannot.
bool listen_at(StreamAcceptor& acceptor, const Address& at, Address* bound, std::string* error);

/// Log lines at a bounded rate: at most `per_second` a second; the rest are counted, and the next line said
/// after them tells how many were left out ("... (41 similar lines left out)").
class RateLimitedLog {
 public:
  explicit RateLimitedLog(int per_second = 10) : per_second_(per_second) {}
  /// `say(line)` now, or counts the line when this second's budget is spent.
  void say(const std::string& line, const std::function<void(const std::string&)>& say);

 private:
  int per_second_;
  std::chrono::steady_clock::time_point window_{};
  int said_ = 0;
  std::uint64_t left_out_ = 0;
};

/// What a listener does when accept fails. Running out of descriptors or memory (EMFILE, ENFILE, ENOBUFS,
/// ENOMEM) does not go away by retrying at once, and retrying at once spins the loop at 100 % CPU: the next
/// accept waits 10 ms, doubling to 1 s, back to nothing after a success. The failures are logged at most once a
/// second (RateLimitedLog). One per listener; everything on the loop's thread.
class AcceptBackoff {
 public:
  explicit AcceptBackoff(boost::asio::io_context& io) : timer_(io), log_(1) {}
  /// After a failed accept on `where`: says so (rate-limited) and calls `retry` after the current delay.
  void failed(const boost::system::error_code& ec, const std::string& where,
              const std::function<void(const std::string&)>& say, std::function<void()> retry);
  /// After a successful accept: the delay goes back to nothing.
  void succeeded() { delay_ = std::chrono::milliseconds(0); }
  /// Cancels a pending retry (the listener closes).
  void cancel();

 private:
  boost::asio::steady_timer timer_;
  std::chrono::milliseconds delay_{0};
  RateLimitedLog log_;
};

/// One stream socket with a read buffer of whole frames and a write queue.
class FramedSocket {
 public:
  using Socket = boost::asio::generic::stream_protocol::socket;
  using error_code = boost::system::error_code;

  /// What the socket tells its owner, from the loop.
  class Owner {
   public:
    virtual ~Owner() = default;
    /// A read ended: `n` more bytes are in unread() (none when `ec`). The owner consumes the whole frames
    /// and calls read() again to go on.
    virtual void on_read(const error_code& ec, std::size_t n) = 0;
    /// A write of `n` queued bytes ended. Unless `ec`, the socket goes on with what was queued meanwhile
    /// (queued() == 0: all written).
    virtual void on_written(const error_code& ec, std::size_t n) = 0;
  };

  FramedSocket(Socket s, Owner& owner);
  FramedSocket(const FramedSocket&) = delete;
  FramedSocket& operator=(const FramedSocket&) = delete;

  Socket& socket() { return socket_; }

  /// Reads what the peer sent next. Room is made first: the unread bytes move to the front and the buffer
  /// doubles when it is nearly full. It grows with the bytes received, never to a declared length (so a
  /// length prefix costs nothing until its bytes come; the owner refuses a prefix over its frame limit), and
  /// goes back to its first size once emptied after a big frame.
  void read(std::shared_ptr<void> keep);
  /// The bytes read and not yet consumed; they start at a frame boundary.
  std::string_view unread() const { return {buf_.data() + begin_, end_ - begin_}; }
  /// Marks the first `n` unread bytes as used.
  void consume(std::size_t n);

  /// The write queue: append whole frames, then flush().
  std::string& queue() { return queue_; }
  /// Bytes queued and not yet handed to a write.
  std::size_t queued() const { return queue_.size(); }
  /// True when nothing is queued or being written.
  bool idle() const { return !writing_ && queue_.empty(); }
  /// Starts writing the queue unless a write is in flight, the queue is empty or the socket is closed.
  void flush(std::shared_ptr<void> keep);
  /// When idle() and the first write of this turn of the loop: writes `parts` at once, as far as the socket
  /// takes them without blocking, and queues the rest (flushed). Else queues them: the frames written after the
  /// first in one turn go in one write when the turn ends (a posted flush). False with `ec` on a socket error
  /// (nothing queued).
  bool write_now(std::span<const std::string_view> parts, std::shared_ptr<void> keep, error_code& ec);
  /// Bytes handed to the socket so far.
  std::uint64_t bytes_out() const { return bytes_out_; }

  /// Shuts the socket down and closes it; pending reads and writes end with an error.
  void close();

 private:
  void make_room();

  Socket socket_;
  Owner& owner_;
  std::vector<char> buf_;
  std::size_t begin_ = 0, end_ = 0;
  std::string queue_, writing_buf_;
  bool writing_ = false;
  bool burst_ = false;  // a frame went out at once in this turn: the next ones wait for its end
  std::uint64_t bytes_out_ = 0;
};

}  // namespace dca
