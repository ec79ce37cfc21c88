// FramedSocket: addresses, listening, whole frames out of a byte stream, writes queued behind a backed-up socket.
#include "host/net/framed_socket.h"

#include <gtest/gtest.h>
#include <sys/socket.h>

#include <boost/asio/local/connect_pair.hpp>
#include <boost/asio/local/stream_protocol.hpp>
#include <chrono>
#include <memory>
#include <string>
#include <vector>

#include "tests/support/run_until.h"

namespace {

using dca::Address;
using dca::FramedSocket;
using dca::test::run_until;

TEST(AddressTest, ParsesTcpAndUnixAddresses) {
  std::string error;
  auto a = Address::parse("127.0.0.1:4000");
  ASSERT_TRUE(a);
  EXPECT_EQ(a->kind, dca::Transport::Tcp);
  EXPECT_EQ(a->port, 4000);
  EXPECT_EQ(a->str(), "127.0.0.1:4000");
  EXPECT_EQ(Address::parse("tcp:localhost:1")->host, "127.0.0.1");
  EXPECT_EQ(Address::parse("[::1]:5")->str(), "[::1]:5");
  auto u = Address::parse("unix:/tmp/x.sock");
  ASSERT_TRUE(u);
  EXPECT_EQ(u->kind, dca::Transport::Unix);
  EXPECT_EQ(u->path, "/tmp/x.sock");
  EXPECT_EQ(*Address::parse("/tmp/x.sock"), *u);
  EXPECT_EQ(*Address::parse(u->str()), *u);
  EXPECT_FALSE(Address::parse("nohost", &error));
  EXPECT_NE(error.find("bad address 'nohost'"), std::string::npos) << error;
  EXPECT_FALSE(Address::parse("127.0.0.1:99999", &error));
  EXPECT_FALSE(Address::parse("example.com:80", &error));
  EXPECT_NE(error.find("numeric IP"), std::string::npos) << error;
}

TEST(FramedSocketListenTest, ListensOnAFreePortAndRefusesABadAddress) {
  boost::asio::io_context io;
  dca::StreamAcceptor acceptor(io);
  Address bound;
  std::string error;
  ASSERT_TRUE(dca::listen_at(acceptor, *Address::parse("127.0.0.1:0"), &bound, &error)) << error;
  EXPECT_EQ(bound.host, "127.0.0.1");
  EXPECT_NE(bound.port, 0);
  dca::StreamAcceptor again(io);
  Address ignored;
  EXPECT_FALSE(dca::listen_at(again, bound, &ignored, &error));
  EXPECT_NE(error.find("cannot listen on " + bound.str()), std::string::npos) << error;
}

// Records what a FramedSocket tells its owner; splits the stream into frames of a 4-byte length + body.
class Recorder : public FramedSocket::Owner, public std::enable_shared_from_this<Recorder> {
 public:
  explicit Recorder(FramedSocket::Socket s) : framed(std::move(s), *this) {}
  void on_read(const boost::system::error_code& ec, std::size_t) override {
    if (ec) {
      failed = true;
      return;
    }
    for (auto in = framed.unread(); in.size() >= 4; in = framed.unread()) {
      const auto* p = reinterpret_cast<const unsigned char*>(in.data());
      const std::size_t len = (std::size_t{p[0]} << 24) | (std::size_t{p[1]} << 16) | (std::size_t{p[2]} << 8) | p[3];
      if (in.size() < 4 + len) break;
      frames.emplace_back(in.substr(4, len));
      framed.consume(4 + len);
    }
    framed.read(shared_from_this());
  }
  void on_written(const boost::system::error_code& ec, std::size_t n) override {
    written += n;
    failed = failed || bool(ec);
  }
  FramedSocket framed;
  std::vector<std::string> frames;
  std::size_t written = 0;
  bool failed = false;
};

std::string frame(const std::string& body) {
  const auto n = static_cast<std::uint32_t>(body.size());
  return std::string{char(n >> 24), char(n >> 16), char(n >> 8), char(n)} + body;
}

class FramedSocketTest : public ::testing::Test {
 protected:
  void SetUp() override {
    boost::asio::local::stream_protocol::socket a(io), b(io);
    boost::asio::local::connect_pair(a, b);
    FramedSocket::Socket ga(io), gb(io);
    ga.assign(boost::asio::generic::stream_protocol(AF_UNIX, 0), a.release());
    gb.assign(boost::asio::generic::stream_protocol(AF_UNIX, 0), b.release());
    ga.non_blocking(true);
    left = std::make_shared<Recorder>(std::move(ga));
    right = std::make_shared<Recorder>(std::move(gb));
    right->framed.read(right);
  }
  boost::asio::io_context io;
  std::shared_ptr<Recorder> left, right;
};

TEST_F(FramedSocketTest, QueuedFramesArriveWholeAndInOrder) {
  left->framed.queue() += frame("one") + frame("") + frame("three");
  EXPECT_FALSE(left->framed.idle());
  left->framed.flush(left);
  ASSERT_TRUE(run_until(io, [&] { return right->frames.size() == 3 && left->framed.idle(); }));
  EXPECT_EQ(right->frames, (std::vector<std::string>{"one", "", "three"}));
  EXPECT_EQ(left->written, 4u + 3 + 4 + 4 + 5);
}

TEST_F(FramedSocketTest, AFrameBiggerThanTheReadBufferGrowsIt) {
  const std::string big(300 * 1024, 'x');
  const std::string f = frame(big);
  boost::system::error_code ec;
  const std::array<std::string_view, 2> parts{std::string_view(f).substr(0, 4), std::string_view(f).substr(4)};
  ASSERT_TRUE(left->framed.write_now(parts, left, ec)) << ec.message();
  ASSERT_TRUE(run_until(io, [&] { return right->frames.size() == 1 && left->framed.idle(); }));
  EXPECT_EQ(right->frames[0], big);
  EXPECT_EQ(left->framed.bytes_out(), f.size());
}

TEST_F(FramedSocketTest, WriteNowQueuesWhatABackedUpSocketDoesNotTake) {
  const std::string body(4 << 20, 'y');  // more than the socket buffers hold while nobody reads
  const std::string f = frame(body);
  boost::system::error_code ec;
  const std::array<std::string_view, 1> parts{f};
  ASSERT_TRUE(left->framed.write_now(parts, left, ec)) << ec.message();
  EXPECT_LT(left->framed.bytes_out(), f.size()) << "the socket took it all at once";
  EXPECT_FALSE(left->framed.idle()) << "the rest is being written";
  ASSERT_TRUE(run_until(io, [&] { return right->frames.size() == 1 && left->framed.idle(); }));
  EXPECT_EQ(right->frames[0], body);
  EXPECT_EQ(left->framed.bytes_out(), f.size());
  EXPECT_FALSE(left->failed);
}

// A turn's first frame goes at once; the ones after it in the same turn wait for its end and go in one write
// (issue #36: one write per sample made a push connection no faster than raw per-frame writes).
TEST_F(FramedSocketTest, TheFramesAfterATurnsFirstGoInOneWriteAtItsEnd) {
  std::vector<std::string> fs;
  for (int i = 0; i < 10; ++i) fs.push_back(frame("sample " + std::to_string(i)));
  boost::system::error_code ec;
  for (const auto& f : fs) {
    const std::array<std::string_view, 1> parts{f};
    ASSERT_TRUE(left->framed.write_now(parts, left, ec)) << ec.message();
  }
  EXPECT_EQ(left->framed.bytes_out(), fs[0].size()) << "only the first went to the kernel in this turn";
  EXPECT_EQ(left->framed.queued(), 9 * fs[1].size());
  EXPECT_FALSE(left->framed.idle());
  ASSERT_TRUE(run_until(io, [&] { return right->frames.size() == 10 && left->framed.idle(); }));
  EXPECT_EQ(left->written, 9 * fs[1].size()) << "the other nine in one write";
  for (int i = 0; i < 10; ++i) EXPECT_EQ(right->frames[i], "sample " + std::to_string(i));
  // the next turn starts at once again
  const std::string next = frame("next");
  const std::array<std::string_view, 1> parts{next};
  const auto before = left->framed.bytes_out();
  ASSERT_TRUE(left->framed.write_now(parts, left, ec));
  EXPECT_EQ(left->framed.bytes_out(), before + next.size());
  EXPECT_TRUE(left->framed.idle());
}

}  // namespace
