#pragma once
// Test support: a hand-made data-plane client on a plain socket, to speak to an Endpoint's data port as an
// attacker would (no handshake, a wrong key, a replayed handshake, oversize or half frames). Writes block (the
// frames are small); reads are polled without blocking while the io_context runs the endpoint under test.
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <arpa/inet.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstring>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <boost/asio/io_context.hpp>

#include "host/codec/data_frame.h"
#include "host/net/auth.h"
#include "host/net/framed_socket.h"
#include "tests/support/run_until.h"

namespace dca::test {

/// One frame as received.
struct RawFrame {
  data_frame::Kind kind = data_frame::Kind::Sample;
  std::uint32_t link = 0;
  std::string body;
};

/// A plain-socket data client connected to `address` ("unix:/path" or "127.0.0.1:PORT").
class RawDataClient {
 public:
  RawDataClient(boost::asio::io_context& io, const std::string& address) : io_(io) {
    const auto a = Address::parse(address);
    if (!a) return;
    if (a->kind == Transport::Unix) {
      sockaddr_un sa{};
      sa.sun_family = AF_UNIX;
      std::strncpy(sa.sun_path, a->path.c_str(), sizeof sa.sun_path - 1);
      fd_ = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
      if (fd_ >= 0 && ::connect(fd_, reinterpret_cast<sockaddr*>(&sa), sizeof sa) != 0) drop();
    } else {
      sockaddr_in sa{};
      sa.sin_family = AF_INET;
      sa.sin_port = htons(a->port);
      ::inet_pton(AF_INET, a->host.c_str(), &sa.sin_addr);
      fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
      if (fd_ >= 0 && ::connect(fd_, reinterpret_cast<sockaddr*>(&sa), sizeof sa) != 0) drop();
    }
  }
  ~RawDataClient() { drop(); }
  RawDataClient(const RawDataClient&) = delete;
  RawDataClient& operator=(const RawDataClient&) = delete;

  bool connected() const { return fd_ >= 0; }

  /// Sends raw bytes (false when the peer has closed).
  bool send_raw(const std::string& bytes) {
    return fd_ >= 0 && ::send(fd_, bytes.data(), bytes.size(), MSG_NOSIGNAL) == static_cast<ssize_t>(bytes.size());
  }
  /// The bytes of a frame of `kind` on `link` with `body`.
  static std::string frame(data_frame::Kind kind, const std::string& body, std::uint32_t link = 1) {
    std::string f(data_frame::kHeader, '\0');
    data_frame::put_header(reinterpret_cast<std::byte*>(f.data()), kind, link, body.size());
    return f + body;
  }
  bool send_frame(data_frame::Kind kind, const std::string& body, std::uint32_t link = 1) {
    return send_raw(frame(kind, body, link));
  }
  /// Introduces this client as an endpoint at `self` (the Peer frame that follows the handshake).
  bool introduce(const Location& self = {}) {
    return send_frame(data_frame::Kind::Peer, data_frame::encode_peer(self), 0);
  }
  /// Sends one handshake message as an Auth frame.
  bool send_auth(const wire::Message& m) { return send_frame(data_frame::Kind::Auth, data_frame::encode_auth(m), 0); }

  /// Runs `io` until a whole frame arrives (nullopt on close, a malformed frame, or 5 s without one).
  std::optional<RawFrame> read_frame() {
    std::optional<RawFrame> got;
    run_until(io_, [&] {
      poll();
      data_frame::Frame f;
      std::size_t used = 0;
      const auto r = data_frame::parse_frame({reinterpret_cast<const std::byte*>(in_.data()), in_.size()}, f, used,
                                             nullptr);
      if (r == data_frame::Parse::Ok) {
        got = RawFrame{f.kind, f.link, std::string(reinterpret_cast<const char*>(f.body.data()), f.body.size())};
        in_.erase(0, used);
        return true;
      }
      return r == data_frame::Parse::Error || eof_;
    });
    return got;
  }

  /// Runs `io` until the peer closes the connection (false after 5 s of it open).
  bool wait_closed() {
    return run_until(io_, [&] {
      poll();
      return eof_;
    });
  }

  /// Runs the client's side of the data handshake with `key` (the data key, see host/net/endpoint.h data_key). ""
  /// when welcomed, else why not. The messages it sent are appended to *sent.
  std::string handshake(const auth::Key& key, std::vector<wire::Message>* sent = nullptr) {
    auth::Handshake hs(auth::Handshake::Role::kClient, key);
    const auto out = [&](const auth::Handshake::Step& s) {
      for (const auto& m : s.out) {
        if (sent) sent->push_back(m);
        send_auth(m);
      }
    };
    out(hs.start());
    for (;;) {
      wire::Message m;
      if (auto why = read_auth(m); !why.empty()) return why;
      auto step = hs.on_message(m);
      out(step);
      if (step.state == auth::Handshake::State::kDone) return "";
      if (step.state == auth::Handshake::State::kFailed) return hs.reason();
    }
  }

  /// Reads one handshake message into `m`: "" or why not (closed, another frame, an error message).
  std::string read_auth(wire::Message& m) {
    const auto f = read_frame();
    if (!f) return "closed without an answer";
    if (f->kind != data_frame::Kind::Auth)
      return "answered with frame kind " + std::to_string(static_cast<int>(f->kind)) + ": " + f->body;
    std::string error;
    if (!data_frame::decode_auth({reinterpret_cast<const std::byte*>(f->body.data()), f->body.size()}, m, &error))
      return error;
    if (m.type == "error") return "refused: " + m.payload["reason"].as_string();
    return "";
  }

 private:
  // Reads what has arrived, without blocking.
  void poll() {
    if (fd_ < 0) {
      eof_ = true;
      return;
    }
    std::array<char, 4096> buf;
    for (;;) {
      const ssize_t n = ::recv(fd_, buf.data(), buf.size(), MSG_DONTWAIT);
      if (n > 0) {
        in_.append(buf.data(), static_cast<std::size_t>(n));
        continue;
      }
      if (n == 0 || (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR)) eof_ = true;
      return;
    }
  }
  void drop() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }

  boost::asio::io_context& io_;
  int fd_ = -1;
  std::string in_;
  bool eof_ = false;
};

}  // namespace dca::test
