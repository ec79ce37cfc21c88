#include "host/net/channel.h"

#include <gtest/gtest.h>
#include <netinet/tcp.h>
#include <unistd.h>

#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/write.hpp>
#include <chrono>

#include "host/loop.h"
#include "tests/support/channel_pair.h"

namespace {

using namespace std::chrono_literals;
using namespace dca::test;  // Address, Channel, ..., kKey

class ChannelTest : public ::testing::Test {
 protected:
  // An echo server: replies to "echo" with its payload, to "count" with nothing (so it times out), and
  // closes on "bye". Records the reasons of refused connections and of closed channels.
  Listener::Ptr serve(const std::string& addr, std::string key = kKey) {
    std::string error;
    auto l = Listener::listen(
        loop_.io(), *Address::parse(addr), ChannelOptions{key},
        [this](Channel::Ptr ch) {
          server_channels_.push_back(ch);
          ch->on_message([this, c = ch.get()](const Message& m) {
            ++server_messages_;
            if (m.type == "echo") c->reply(m, m.payload);
            if (m.type == "bye") c->close("bye");
          });
          ch->on_close([this](const std::string& why) { server_closed_.push_back(why); });
        },
        &error, [this](const std::string& why) { refused_.push_back(why); });
    EXPECT_TRUE(l) << error;
    return l;
  }

  Channel::Ptr connect(const Address& to, std::string key = kKey, std::string* error = nullptr,
                       std::chrono::milliseconds timeout = 5000ms) {
    ChannelOptions o{std::move(key)};
    o.handshake_timeout = timeout;
    std::string err;
    auto ch = connect_channel(loop_, to, o, &err);
    EXPECT_NE(err, "connect never finished");
    if (error != nullptr) *error = err;
    return ch;
  }

  // A client with `key` is refused: its error contains `client_says`, the server's refusal `server_says`.
  void expect_refused(const std::string& key, const std::string& client_says, const std::string& server_says) {
    auto l = serve("127.0.0.1:0");
    std::string error;
    auto ch = connect(l->address(), key, &error);
    EXPECT_FALSE(ch);
    EXPECT_NE(error.find(client_says), std::string::npos) << error;
    ASSERT_TRUE(loop_.run_until([&] { return !refused_.empty(); }, 10s));
    EXPECT_NE(refused_[0].find(server_says), std::string::npos) << refused_[0];
  }

  Response call(Channel& ch, Message m, std::chrono::milliseconds timeout = 5000ms) {
    Response r;
    int calls = 0;
    ch.request(std::move(m), timeout, [&](Response got) {
      r = std::move(got);
      ++calls;
    });
    EXPECT_TRUE(loop_.run_until([&] { return calls > 0; }, 10s));
    loop_.run_for(1ms);
    EXPECT_EQ(calls, 1) << "a request's callback runs exactly once";
    return r;
  }

  dca::Loop loop_;
  std::vector<Channel::Ptr> server_channels_;
  std::vector<std::string> refused_, server_closed_;
  int server_messages_ = 0;
};

TEST_F(ChannelTest, RequestReplyOverTcp) {
  auto l = serve("127.0.0.1:0");
  ASSERT_NE(l->address().port, 0);
  auto ch = connect(l->address());
  ASSERT_TRUE(ch);
  const auto r = call(*ch, Message{"echo", 0, Value::map().set("x", 42).set("s", "hi")});
  EXPECT_TRUE(r.ok()) << r.error;
  EXPECT_EQ(r.message.type, "ok");
  EXPECT_EQ(r.message.payload["x"].as_int(), 42);
  EXPECT_EQ(r.message.payload["s"].as_string(), "hi");
  int nodelay = 0;
  socklen_t len = sizeof nodelay;
  ASSERT_EQ(::getsockopt(ch->socket().native_handle(), IPPROTO_TCP, TCP_NODELAY, &nodelay, &len), 0);
  EXPECT_NE(nodelay, 0) << "TCP_NODELAY is set";
}

TEST_F(ChannelTest, RequestReplyOverUnixSocket) {
  const std::string path = "/tmp/dca_channel_test_" + std::to_string(::getpid()) + ".sock";
  auto l = serve("unix:" + path);
  auto ch = connect(l->address());
  ASSERT_TRUE(ch);
  const auto r = call(*ch, Message{"echo", 0, Value::map().set("x", 7)});
  EXPECT_TRUE(r.ok()) << r.error;
  EXPECT_EQ(r.message.payload["x"].as_int(), 7);
  l->close();
  EXPECT_NE(::access(path.c_str(), F_OK), 0) << "the socket file is removed";
}

TEST_F(ChannelTest, ManyMessagesArriveInOrderAndLargeOnesCross) {
  auto l = serve("127.0.0.1:0");
  auto ch = connect(l->address());
  ASSERT_TRUE(ch);
  std::vector<std::int64_t> got;
  for (int i = 0; i < 500; ++i)
    ch->request(Message{"echo", 0, Value::map().set("i", i)}, 5000ms,
                [&](Response r) { got.push_back(r.message.payload["i"].as_int(-1)); });
  ASSERT_TRUE(loop_.run_until([&] { return got.size() == 500; }, 10s));
  for (int i = 0; i < 500; ++i) EXPECT_EQ(got[static_cast<std::size_t>(i)], i);
  const std::string big(3 << 20, 'z');
  const auto r = call(*ch, Message{"echo", 0, Value::map().set("big", big)});
  EXPECT_TRUE(r.ok()) << r.error;
  EXPECT_EQ(r.message.payload["big"].as_string().size(), big.size());
}

TEST_F(ChannelTest, RequestWithoutReplyTimesOutOnce) {
  auto l = serve("127.0.0.1:0");
  auto ch = connect(l->address());
  ASSERT_TRUE(ch);
  const auto r = call(*ch, Message{"count", 0, Value::map()}, 50ms);
  EXPECT_FALSE(r.ok());
  EXPECT_FALSE(r.replied());
  EXPECT_NE(r.error.find("timeout: no reply to 'count'"), std::string::npos) << r.error;
  EXPECT_EQ(ch->pending_requests(), 0u);
  EXPECT_TRUE(ch->is_open()) << "a timeout does not close the channel";
}

TEST_F(ChannelTest, ErrorReplyCarriesItsReason) {
  auto l = serve("127.0.0.1:0");
  std::string error;
  auto ch = connect(l->address());
  ASSERT_TRUE(ch);
  // The server's handler ignores "nothing"; a server channel without a handler answers with an error.
  server_channels_.back()->on_message(nullptr);
  const auto r = call(*ch, Message{"nothing", 0, Value::map()});
  EXPECT_TRUE(r.replied());
  EXPECT_EQ(r.message.type, "error");
  EXPECT_EQ(r.error, "no handler for 'nothing' on this channel");
}

TEST_F(ChannelTest, PeerCloseFailsPendingRequestsAndIsReportedOnce) {
  auto l = serve("127.0.0.1:0");
  auto ch = connect(l->address());
  ASSERT_TRUE(ch);
  std::vector<std::string> closes;
  ch->on_close([&](const std::string& why) { closes.push_back(why); });
  Response pending;
  int calls = 0;
  ch->request(Message{"count", 0, Value::map()}, 10000ms, [&](Response r) {
    pending = std::move(r);
    ++calls;
  });
  ch->send(Message{"bye", 0, Value::map()});
  ASSERT_TRUE(loop_.run_until([&] { return !closes.empty() && calls == 1; }, 10s));
  loop_.run_for(5ms);
  EXPECT_EQ(closes.size(), 1u);
  EXPECT_EQ(calls, 1);
  EXPECT_NE(closes[0].find("closed by the peer"), std::string::npos) << closes[0];
  EXPECT_NE(pending.error.find("closed"), std::string::npos) << pending.error;
  EXPECT_FALSE(ch->send(Message{"echo", 0, Value::map()})) << "sending on a closed channel fails";
  // A request on a closed channel fails from the loop, never silently.
  const auto r = call(*ch, Message{"echo", 0, Value::map()});
  EXPECT_NE(r.error.find("is closed"), std::string::npos) << r.error;
}

TEST_F(ChannelTest, WrongKeyIsRefusedWithAReasonOnBothSides) {
  expect_refused("a different key of 32 bytes.....", "key check", "wrong cluster key");
  EXPECT_TRUE(server_channels_.empty()) << "no channel reaches the server's handler";
}

TEST_F(ChannelTest, ClientWithoutKeyIsRefused) { expect_refused("", "no cluster key", "the peer has no cluster key"); }

// A raw socket that speaks without authenticating: refused, and the server runs nothing.
TEST_F(ChannelTest, UnauthenticatedRequestIsRefused) {
  auto l = serve("127.0.0.1:0");
  boost::asio::ip::tcp::socket raw(loop_.io());
  raw.connect({boost::asio::ip::make_address("127.0.0.1"), l->address().port});
  const std::string frame = dca::wire::encode(Message{"spawn", 1, Value::map().set("argv", Value::Array{"x"})});
  boost::asio::write(raw, boost::asio::buffer(frame));
  ASSERT_TRUE(loop_.run_until([&] { return !refused_.empty(); }, 10s));
  EXPECT_NE(refused_[0].find("expected a handshake hello, got 'spawn'"), std::string::npos) << refused_[0];
  EXPECT_EQ(server_messages_, 0);
  // The peer is told why before the connection closes.
  std::string got(4096, '\0');
  boost::system::error_code ec;
  std::size_t n = 0;
  for (int i = 0; i < 100 && !ec; ++i) {
    loop_.run_for(1ms);
    raw.non_blocking(true);
    const std::size_t k = raw.read_some(boost::asio::buffer(got.data() + n, got.size() - n), ec);
    if (ec == boost::asio::error::would_block) ec = {};
    n += k;
  }
  const auto d = dca::wire::decode_frame(std::string_view(got.data(), n));
  ASSERT_EQ(d.status, dca::wire::Decoded::Status::kMessage) << d.error;
  EXPECT_EQ(d.message.type, "error");
  EXPECT_NE(d.message.payload["reason"].as_string().find("authentication required"), std::string::npos);
}

TEST_F(ChannelTest, MalformedFrameClosesOnlyThatConnection) {
  auto l = serve("127.0.0.1:0");
  auto good = connect(l->address());
  auto bad = connect(l->address());
  ASSERT_TRUE(good && bad);
  std::string bad_closed;
  bad->on_close([&](const std::string& why) { bad_closed = why; });
  // Authenticated, then garbage straight onto the socket: a frame whose body is not msgpack.
  const std::string garbage("\x00\x00\x00\x03\xc1\xc1\xc1", 7);
  boost::asio::write(bad->socket(), boost::asio::buffer(garbage));
  ASSERT_TRUE(loop_.run_until([&] { return !bad_closed.empty(); }, 10s));
  EXPECT_NE(bad_closed.find("closed by the peer"), std::string::npos) << bad_closed;
  EXPECT_NE(bad_closed.find("malformed frame"), std::string::npos) << bad_closed;
  ASSERT_TRUE(loop_.run_until([&] { return !server_closed_.empty(); }, 10s));
  EXPECT_NE(server_closed_[0].find("malformed frame"), std::string::npos) << server_closed_[0];
  const auto r = call(*good, Message{"echo", 0, Value::map().set("still", true)});
  EXPECT_TRUE(r.ok()) << r.error;
  EXPECT_TRUE(r.message.payload["still"].as_bool());
}

TEST_F(ChannelTest, OversizeFrameClosesTheConnection) {
  std::string error;
  ChannelOptions small{kKey};
  small.max_frame = 1024;
  std::vector<std::string> closed;
  auto l = Listener::listen(
      loop_.io(), *Address::parse("127.0.0.1:0"), small,
      [&](Channel::Ptr ch) { ch->on_close([&](const std::string& why) { closed.push_back(why); }); }, &error);
  ASSERT_TRUE(l) << error;
  auto ch = connect(l->address());
  ASSERT_TRUE(ch);
  ch->send(Message{"blob", 0, Value::map().set("b", std::string(4096, 'b'))});
  ASSERT_TRUE(loop_.run_until([&] { return !closed.empty(); }, 10s));
  EXPECT_NE(closed[0].find("exceeds the limit of 1024"), std::string::npos) << closed[0];
}

TEST_F(ChannelTest, ConnectingToNothingFailsWithTheAddress) {
  // Bind a port, then close it, so nothing listens there.
  boost::asio::ip::tcp::acceptor a(loop_.io(), {boost::asio::ip::make_address("127.0.0.1"), 0});
  const auto port = a.local_endpoint().port();
  a.close();
  std::string error;
  auto ch = connect(*Address::parse("127.0.0.1:" + std::to_string(port)), kKey, &error);
  EXPECT_FALSE(ch);
  EXPECT_NE(error.find("cannot connect to 127.0.0.1:" + std::to_string(port)), std::string::npos) << error;
}

TEST_F(ChannelTest, SilentServerTimesOutTheHandshake) {
  boost::asio::ip::tcp::acceptor a(loop_.io(), {boost::asio::ip::make_address("127.0.0.1"), 0});
  boost::asio::ip::tcp::socket accepted(loop_.io());
  a.async_accept(accepted, [](const boost::system::error_code&) {});
  std::string error;
  auto ch = connect(*Address::parse("127.0.0.1:" + std::to_string(a.local_endpoint().port())), kKey, &error, 100ms);
  EXPECT_FALSE(ch);
  EXPECT_NE(error.find("timed out"), std::string::npos) << error;
}

TEST_F(ChannelTest, SilentClientIsDroppedAfterTheHandshakeTimeout) {
  std::string error;
  ChannelOptions o{kKey};
  o.handshake_timeout = 100ms;
  auto l = Listener::listen(
      loop_.io(), *Address::parse("127.0.0.1:0"), o, [](Channel::Ptr) {}, &error,
      [&](const std::string& why) { refused_.push_back(why); });
  ASSERT_TRUE(l) << error;
  boost::asio::ip::tcp::socket raw(loop_.io());
  raw.connect({boost::asio::ip::make_address("127.0.0.1"), l->address().port});
  ASSERT_TRUE(loop_.run_until([&] { return !refused_.empty(); }, 10s));
  EXPECT_NE(refused_[0].find("timed out"), std::string::npos) << refused_[0];
}

TEST_F(ChannelTest, CloseRunsOnCloseOnceAndFailsPending) {
  auto l = serve("127.0.0.1:0");
  auto ch = connect(l->address());
  ASSERT_TRUE(ch);
  int closes = 0, fails = 0;
  ch->on_close([&](const std::string& why) {
    ++closes;
    EXPECT_EQ(why, "done here");
  });
  ch->request(Message{"count", 0, Value::map()}, 10000ms, [&](Response r) { fails += r.ok() ? 0 : 1; });
  ch->close("done here");
  ch->close("again");
  EXPECT_EQ(closes, 1);
  EXPECT_EQ(fails, 1);
  // The server sees the close as an event, not a hang.
  ASSERT_TRUE(loop_.run_until([&] { return !server_closed_.empty(); }, 10s));
  EXPECT_NE(server_closed_[0].find("connection closed by the peer"), std::string::npos) << server_closed_[0];
}

}  // namespace
