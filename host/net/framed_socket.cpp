#include "host/net/framed_socket.h"

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
#include <algorithm>
#include <array>
#include <charconv>
#include <cstring>

namespace dca {
namespace asio = boost::asio;
using boost::system::error_code;

namespace {

constexpr std::size_t kReadChunk = 16 * 1024;     // the read buffer's first size
constexpr std::size_t kMinRoom = 1024;            // free bytes below which the buffer doubles before a read
constexpr std::size_t kShrinkAbove = 256 * 1024;  // an emptied buffer larger than this goes back to kReadChunk

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
    a.kind = Transport::Unix;
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
  if (kind == Transport::Unix) return "unix:" + path;
  if (host.find(':') != std::string::npos) return "[" + host + "]:" + std::to_string(port);
  return host + ":" + std::to_string(port);
}

Address Address::unix_socket(std::string path) {
  Address a;
  a.kind = Transport::Unix;
  a.path = std::move(path);
  return a;
}

std::string endpoint_str(const StreamEndpoint& ep) {
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

std::optional<StreamEndpoint> to_endpoint(const Address& a, std::string* error) {
  if (a.kind == Transport::Unix) {
    if (a.path.size() >= sizeof(sockaddr_un::sun_path)) {
      if (error != nullptr) *error = "socket path too long: " + a.path;
      return std::nullopt;
    }
    return StreamEndpoint(asio::local::stream_protocol::endpoint(a.path));
  }
  error_code ec;
  const auto ip = asio::ip::make_address(a.host, ec);
  if (ec) {
    if (error != nullptr) *error = "bad IP address '" + a.host + "'";
    return std::nullopt;
  }
  return StreamEndpoint(asio::ip::tcp::endpoint(ip, a.port));
}

bool listen_at(StreamAcceptor& acceptor, const Address& at, Address* bound, std::string* error) {
  const auto ep = to_endpoint(at, error);
  if (!ep) return false;
  const auto fail = [&](const char* what, const error_code& ec) {
    if (error != nullptr) *error = std::string("cannot listen on ") + at.str() + ": " + what + ": " + ec.message();
    return false;
  };
  if (at.kind == Transport::Unix) {
    struct stat st {};
    if (::lstat(at.path.c_str(), &st) == 0 && S_ISSOCK(st.st_mode)) ::unlink(at.path.c_str());
  }
  error_code ec;
  acceptor.open(ep->protocol(), ec);
  if (ec) return fail("open", ec);
  if (at.kind == Transport::Tcp) acceptor.set_option(asio::socket_base::reuse_address(true), ec);
  acceptor.bind(*ep, ec);
  if (ec) return fail("bind", ec);
  acceptor.listen(asio::socket_base::max_listen_connections, ec);
  if (ec) return fail("listen", ec);
  *bound = at;
  if (at.kind == Transport::Tcp) {
    const auto local = acceptor.local_endpoint(ec);
    if (!ec) {
      if (auto parsed = Address::parse(endpoint_str(local))) *bound = *parsed;
    }
  }
  return true;
}

// ------------------------------------------------------------------------------ RateLimitedLog, AcceptBackoff

void RateLimitedLog::say(const std::string& line, const std::function<void(const std::string&)>& say) {
  const auto now = std::chrono::steady_clock::now();
  if (now - window_ >= std::chrono::seconds(1)) {
    window_ = now;
    said_ = 0;
  }
  if (said_ >= per_second_) {
    ++left_out_;
    return;
  }
  ++said_;
  if (!say) return;
  if (left_out_ == 0) return say(line);
  say(line + " (" + std::to_string(left_out_) + " similar lines left out)");
  left_out_ = 0;
}

void AcceptBackoff::failed(const error_code& ec, const std::string& where,
                           const std::function<void(const std::string&)>& say, std::function<void()> retry) {
  using std::chrono::milliseconds;
  delay_ = delay_ == milliseconds(0) ? milliseconds(10) : std::min(delay_ * 2, milliseconds(1000));
  log_.say("accept failed on " + where + ": " + ec.message() + "; retrying in " + std::to_string(delay_.count()) +
               " ms",
           say);
  timer_.expires_after(delay_);
  timer_.async_wait([retry = std::move(retry)](const error_code& tec) {
    if (!tec) retry();
  });
}

void AcceptBackoff::cancel() {
  error_code ec;
  timer_.cancel(ec);
}

// ----------------------------------------------------------------------------------------------- FramedSocket

FramedSocket::FramedSocket(Socket s, Owner& owner) : socket_(std::move(s)), owner_(owner), buf_(kReadChunk) {}

void FramedSocket::make_room() {
  if (begin_ > 0) {
    std::memmove(buf_.data(), buf_.data() + begin_, end_ - begin_);
    end_ -= begin_;
    begin_ = 0;
  }
  // Grow with the bytes that came, never to a frame's declared length: a peer that announces 16 MiB and sends
  // nothing more costs nothing. A big frame that does arrive is gathered in O(log n) doublings.
  if (buf_.size() - end_ < kMinRoom) buf_.resize(buf_.size() * 2);
}

void FramedSocket::read(std::shared_ptr<void> keep) {
  make_room();
  socket_.async_read_some(asio::buffer(buf_.data() + end_, buf_.size() - end_),
                          [this, keep = std::move(keep)](const error_code& ec, std::size_t n) {
                            if (!ec) end_ += n;
                            owner_.on_read(ec, ec ? 0 : n);
                          });
}

void FramedSocket::consume(std::size_t n) {
  begin_ += n;
  if (begin_ != end_) return;
  begin_ = end_ = 0;
  if (buf_.size() > kShrinkAbove) std::vector<char>(kReadChunk).swap(buf_);  // after a big frame
}

void FramedSocket::flush(std::shared_ptr<void> keep) {
  if (writing_ || queue_.empty() || !socket_.is_open()) return;
  writing_buf_.swap(queue_);
  queue_.clear();
  writing_ = true;
  asio::async_write(socket_, asio::buffer(writing_buf_),
                    [this, keep = std::move(keep)](const error_code& ec, std::size_t n) mutable {
                      writing_ = false;
                      bytes_out_ += n;
                      writing_buf_.clear();
                      owner_.on_written(ec, n);
                      if (!ec) flush(std::move(keep));
                    });
}

// The first frame of a turn of the loop goes to the kernel at once (a lone sample waits for nothing); the ones
// after it in the same turn are queued and written together when the turn ends, one write for the burst (a
// controller's outputs to one peer, a backlog of samples) instead of one each.
bool FramedSocket::write_now(std::span<const std::string_view> parts, std::shared_ptr<void> keep, error_code& ec) {
  std::size_t total = 0, written = 0;
  for (const auto& p : parts) total += p.size();
  if (idle() && !burst_) {
    std::array<asio::const_buffer, 4> bufs;
    std::size_t k = 0;
    for (const auto& p : parts)
      if (k < bufs.size()) bufs[k++] = asio::buffer(p.data(), p.size());
    written = socket_.write_some(std::span(bufs.data(), k), ec);
    bytes_out_ += written;
    if (!ec && written == total) {
      burst_ = true;
      asio::post(socket_.get_executor(), [this, keep = std::move(keep)]() mutable {
        burst_ = false;
        flush(std::move(keep));
      });
      return true;
    }
    if (ec && ec != asio::error::would_block && ec != asio::error::try_again) return false;
    ec.clear();
  }
  for (const auto& p : parts) {  // queue what was not written
    const std::size_t skip = std::min(written, p.size());
    queue_.append(p.data() + skip, p.size() - skip);
    written -= skip;
  }
  if (!burst_) flush(std::move(keep));  // (in a burst: when its turn ends)
  return true;
}

void FramedSocket::close() {
  error_code ec;
  socket_.shutdown(asio::socket_base::shutdown_both, ec);
  socket_.close(ec);
}

}  // namespace dca
