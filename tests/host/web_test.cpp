// web::Server: pages with and without the token, WebSocket subprotocols, auth refused, bad and oversize input,
// slow clients (bounded queues), live samples (decimated), all on one io_context with async clients.
#include "host/web/web.h"

#include <gtest/gtest.h>

#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/read.hpp>
#include <boost/asio/write.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "host/codec/json.h"
#include "tests/support/run_until.h"

namespace {

namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = boost::asio::ip::tcp;
using dca::test::run_until;

// Echoes every message back; remembers what happened.
struct Echo : dca::web::Protocol {
  int opened = 0, closed = 0;
  std::vector<std::string> got;
  std::string close_reason;
  dca::web::Connection::Ptr last;
  void on_open(const dca::web::Connection::Ptr& c) override {
    opened++;
    last = c;
  }
  void on_message(const dca::web::Connection::Ptr& c, std::string_view data, bool binary) override {
    got.emplace_back(data);
    c->send(std::string(data), binary);
  }
  void on_close(const dca::web::Connection::Ptr&, const std::string& reason) override {
    closed++;
    close_reason = reason;
  }
};

class WebServerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string error;
    server = dca::web::Server::listen(io, *dca::Address::parse("127.0.0.1:0"), limits(), &error);
    ASSERT_TRUE(server) << error;
    server->set_page("/", {"text/html", "<html>page</html>"}, true);
    server->set_page("/data", {"text/plain", "secret"}, false);
    echo = std::make_shared<Echo>();
    server->add_protocol("test.echo", echo);
  }
  virtual dca::web::Limits limits() {
    dca::web::Limits l;
    l.max_message_bytes = 1024;
    l.max_queue_bytes = 64 * 1024;
    l.close_queue_bytes = 256 * 1024;
    l.sample_flush = std::chrono::milliseconds(10);
    return l;
  }
  tcp::endpoint endpoint() const {
    return {boost::asio::ip::make_address("127.0.0.1"), server->address().port};
  }
  // A GET of `target`; the status code (0: no answer).
  int get(const std::string& target, std::string* body = nullptr) {
    beast::tcp_stream s(io);
    http::request<http::empty_body> req{http::verb::get, target, 11};
    http::response<http::string_body> res;
    beast::flat_buffer buf;
    bool done = false;
    s.async_connect(endpoint(), [&](beast::error_code ec) {
      if (ec) { done = true; return; }
      http::async_write(s, req, [&](beast::error_code wec, std::size_t) {
        if (wec) { done = true; return; }
        http::async_read(s, buf, res, [&](beast::error_code, std::size_t) { done = true; });
      });
    });
    EXPECT_TRUE(run_until(io, [&] { return done; }));
    if (body) *body = res.body();
    return static_cast<int>(res.result_int());
  }
  // A WebSocket handshake at `target` offering `protocol`; the error ("" on success).
  std::string ws_connect(websocket::stream<beast::tcp_stream>& ws, const std::string& target,
                         const std::string& protocol = "test.echo") {
    bool done = false;
    beast::error_code result;
    ws.set_option(websocket::stream_base::decorator([protocol](websocket::request_type& r) {
      if (!protocol.empty()) r.set(http::field::sec_websocket_protocol, protocol);
    }));
    beast::get_lowest_layer(ws).async_connect(endpoint(), [&](beast::error_code ec) {
      if (ec) { result = ec; done = true; return; }
      ws.async_handshake("127.0.0.1", target, [&](beast::error_code hec) { result = hec; done = true; });
    });
    EXPECT_TRUE(run_until(io, [&] { return done; }));
    return result ? result.message() : "";
  }
  // One message read from `ws` (empty on an error, with *error set).
  std::string ws_read(websocket::stream<beast::tcp_stream>& ws, std::string* error = nullptr) {
    beast::flat_buffer buf;
    bool done = false;
    beast::error_code result;
    ws.async_read(buf, [&](beast::error_code ec, std::size_t) { result = ec; done = true; });
    EXPECT_TRUE(run_until(io, [&] { return done; }));
    if (error) *error = result ? result.message() : "";
    return result ? "" : beast::buffers_to_string(buf.data());
  }
  bool ws_write(websocket::stream<beast::tcp_stream>& ws, const std::string& text) {
    bool done = false;
    beast::error_code result;
    ws.async_write(boost::asio::buffer(text), [&](beast::error_code ec, std::size_t) { result = ec; done = true; });
    EXPECT_TRUE(run_until(io, [&] { return done; }));
    return !result;
  }
  std::string with_token(const std::string& path) { return path + "?token=" + server->token(); }

  boost::asio::io_context io;
  dca::web::Server::Ptr server;
  std::shared_ptr<Echo> echo;
};

TEST_F(WebServerTest, PublicPagesLoadAndDataPagesNeedTheToken) {
  std::string body;
  EXPECT_EQ(get("/", &body), 200);
  EXPECT_EQ(body, "<html>page</html>");
  EXPECT_EQ(get("/data", &body), 401);
  EXPECT_EQ(body.find("secret"), std::string::npos);
  EXPECT_EQ(get("/data?token=0123456789abcdef0123456789abcdef"), 401);
  EXPECT_EQ(get(with_token("/data"), &body), 200);
  EXPECT_EQ(body, "secret");
  EXPECT_EQ(get("/nothing"), 404);
  EXPECT_EQ(server->token().size(), 32u);
  EXPECT_GE(server->stats().refused, 2u);
}

TEST_F(WebServerTest, WebSocketWithoutTheTokenIsRefused) {
  websocket::stream<beast::tcp_stream> ws(io);
  EXPECT_NE(ws_connect(ws, "/ws"), "");
  websocket::stream<beast::tcp_stream> ws2(io);
  EXPECT_NE(ws_connect(ws2, "/ws?token=wrong"), "");
  EXPECT_EQ(echo->opened, 0);
  EXPECT_EQ(server->stats().refused, 2u);
}

TEST_F(WebServerTest, WebSocketWithTheTokenSpeaksTheChosenSubprotocol) {
  websocket::stream<beast::tcp_stream> ws(io);
  ASSERT_EQ(ws_connect(ws, with_token("/ws"), "other.v1, test.echo"), "");
  ASSERT_TRUE(run_until(io, [&] { return echo->opened == 1; }));
  EXPECT_EQ(echo->last->protocol(), "test.echo");
  ASSERT_TRUE(ws_write(ws, "hello"));
  EXPECT_EQ(ws_read(ws), "hello");
  // an unknown subprotocol is refused; none offered gets the first registered one
  websocket::stream<beast::tcp_stream> ws2(io);
  EXPECT_NE(ws_connect(ws2, with_token("/ws"), "nobody.v1"), "");
  websocket::stream<beast::tcp_stream> ws3(io);
  EXPECT_EQ(ws_connect(ws3, with_token("/ws"), ""), "");
  ASSERT_TRUE(run_until(io, [&] { return echo->opened == 2; }));
}

// Opens `n` TCP sockets to the server that never send a byte (each one accepted before the next is opened).
std::vector<std::unique_ptr<tcp::socket>> idle_sockets(boost::asio::io_context& io, const tcp::endpoint& at,
                                                       const dca::web::Server& server, int n) {
  std::vector<std::unique_ptr<tcp::socket>> out;
  for (int i = 0; i < n; ++i) {
    auto s = std::make_unique<tcp::socket>(io);
    bool done = false;
    const auto accepted = [&] { return server.stats().http_requests + server.stats().open + server.stats().evicted; };
    const auto before = accepted();
    s->async_connect(at, [&](boost::system::error_code) { done = true; });
    EXPECT_TRUE(run_until(io, [&] { return done && accepted() > before; }));
    out.push_back(std::move(s));
  }
  return out;
}

TEST_F(WebServerTest, IdleSocketsWithoutTheTokenCannotKeepATokenHolderOut) {
  // four times the pending pool and more than max_connections: the oldest idle ones are closed as newer come
  auto idle = idle_sockets(io, endpoint(), *server, 80);
  EXPECT_EQ(server->stats().evicted, 80u - dca::web::Limits{}.max_unauthenticated);
  websocket::stream<beast::tcp_stream> operator_ws(io);
  ASSERT_EQ(ws_connect(operator_ws, with_token("/ws")), "");
  ASSERT_TRUE(run_until(io, [&] { return echo->opened == 1; }));
  EXPECT_EQ(server->stats().authenticated, 1u);
  // more strangers later take nothing from the token holder: its socket is no longer pending
  auto more = idle_sockets(io, endpoint(), *server, 40);
  ASSERT_TRUE(ws_write(operator_ws, "abort"));
  EXPECT_EQ(ws_read(operator_ws), "abort");
  EXPECT_EQ(get(with_token("/data")), 200);
  EXPECT_LE(server->stats().open, 1u + dca::web::Limits{}.max_unauthenticated + 1u);
}

TEST_F(WebServerTest, ASocketThatNeverPresentsTheTokenIsClosedAtTheDeadline) {
  auto idle = idle_sockets(io, endpoint(), *server, 1);
  char byte = 0;
  bool closed = false;
  idle.front()->async_read_some(boost::asio::buffer(&byte, 1), [&](boost::system::error_code ec, std::size_t) {
    closed = static_cast<bool>(ec);
  });
  // the server's auth_timeout (3 s by default) ends it: waited for as an event, bounded far beyond it
  ASSERT_TRUE(run_until(io, [&] { return closed; }, std::chrono::seconds(60)));
  EXPECT_TRUE(run_until(io, [&] { return server->stats().open == 0; }));
}

TEST_F(WebServerTest, AnOversizeMessageClosesThatConnectionOnly) {
  websocket::stream<beast::tcp_stream> big(io), other(io);
  ASSERT_EQ(ws_connect(big, with_token("/ws")), "");
  ASSERT_EQ(ws_connect(other, with_token("/ws")), "");
  ws_write(big, std::string(100 * 1024, 'x'));
  std::string error;
  ws_read(big, &error);
  EXPECT_NE(error, "");
  ASSERT_TRUE(run_until(io, [&] { return echo->closed == 1; }));
  EXPECT_GE(server->stats().over_limit, 1u);
  ASSERT_TRUE(ws_write(other, "still here"));
  EXPECT_EQ(ws_read(other), "still here");
}

TEST_F(WebServerTest, GarbageAndMalformedRequestsNeverHurtTheServer) {
  std::mt19937 rng(7);
  for (int round = 0; round < 50; round++) {
    tcp::socket s(io);
    s.connect(endpoint());
    std::string junk(static_cast<std::size_t>(rng() % 4000) + 1, '\0');
    for (auto& c : junk) c = static_cast<char>(rng());
    if (round % 5 == 0) junk = "GET / HTTP/1.1\r\nHost: x\r\n" + std::string(40000, 'a') + "\r\n\r\n";
    if (round % 5 == 1) junk = "GET /ws?token=" + server->token() + " HTTP/1.1\r\nUpgrade: websocket\r\n\r\n";
    bool written = false;
    boost::asio::async_write(s, boost::asio::buffer(junk), [&](beast::error_code, std::size_t) { written = true; });
    ASSERT_TRUE(run_until(io, [&] { return written; }));
    std::string answer(64, '\0');
    bool read = false;
    s.async_read_some(boost::asio::buffer(answer), [&](beast::error_code, std::size_t) { read = true; });
    ASSERT_TRUE(run_until(io, [&] { return read; }, std::chrono::seconds(15)));
  }
  EXPECT_EQ(get("/"), 200);
  EXPECT_GT(server->stats().bad_requests + server->stats().over_limit, 0u);
}

// After an accepted upgrade, frames of random bytes (bad opcodes, reserved bits, unmasked, lengths up to 2^63,
// invalid UTF-8 in text): each connection is closed or left waiting, the protocol handler sees at most whole
// messages, and a well-behaved client is served throughout.
TEST_F(WebServerTest, RandomWebSocketFramesCloseOnlyTheirConnection) {
  std::mt19937 rng(19);
  const std::string upgrade = "GET /ws?token=" + server->token() +
                              " HTTP/1.1\r\nHost: x\r\nConnection: Upgrade\r\nUpgrade: websocket\r\n"
                              "Sec-WebSocket-Version: 13\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n"
                              "Sec-WebSocket-Protocol: test.echo\r\n\r\n";
  websocket::stream<beast::tcp_stream> good(io);
  ASSERT_EQ(ws_connect(good, with_token("/ws")), "");
  for (int round = 0; round < 60; round++) {
    tcp::socket s(io);
    s.connect(endpoint());
    std::string frames;
    const int n = 1 + static_cast<int>(rng() % 4);
    for (int f = 0; f < n; f++) {
      frames += static_cast<char>(rng());                         // FIN, RSV, opcode: anything
      frames += static_cast<char>((rng() % 3 ? 0x80 : 0) | (rng() % 128));  // mask bit, length (126/127: longer)
      std::string rest(rng() % 64, '\0');
      for (auto& c : rest) c = static_cast<char>(rng());
      frames += rest;
    }
    const std::string bytes = upgrade + frames;
    bool written = false;
    boost::asio::async_write(s, boost::asio::buffer(bytes), [&](beast::error_code, std::size_t) { written = true; });
    ASSERT_TRUE(run_until(io, [&] { return written; }));
    ASSERT_TRUE(ws_write(good, "ping " + std::to_string(round)));
    ASSERT_EQ(ws_read(good), "ping " + std::to_string(round));
    s.close();
  }
  ASSERT_TRUE(run_until(io, [&] { return server->stats().open == 1; })) << server->stats().open;
}

TEST_F(WebServerTest, ASlowClientCostsBoundedMemoryAndIsClosedWhenItWouldCostMore) {
  websocket::stream<beast::tcp_stream> ws(io);
  ASSERT_EQ(ws_connect(ws, with_token("/ws")), "");
  ASSERT_TRUE(run_until(io, [&] { return echo->opened == 1; }));
  auto c = echo->last;
  // the client reads nothing: droppable messages beyond the queue's bound are dropped, counted
  const std::string chunk(8 * 1024, 'd');
  for (int i = 0; i < 2000; i++) c->send(chunk, false, true);
  io.restart();
  io.poll();
  EXPECT_GT(c->stats().dropped, 0u);
  EXPECT_LE(c->stats().queued_bytes, 64u * 1024);
  EXPECT_TRUE(c->is_open());
  // messages that must arrive: past close_queue_bytes the connection is closed as too slow
  bool refused = false;
  for (int i = 0; i < 2000 && !refused; i++) refused = !c->send(chunk, false, false);
  EXPECT_TRUE(refused);
  EXPECT_FALSE(c->is_open());
  ASSERT_TRUE(run_until(io, [&] { return echo->closed == 1; }));
  EXPECT_NE(echo->close_reason.find("too slow"), std::string::npos) << echo->close_reason;
  EXPECT_EQ(get("/"), 200);
}

TEST_F(WebServerTest, SubscribedSamplesArriveDecimatedAsJsonRows) {
  websocket::stream<beast::tcp_stream> ws(io);
  ASSERT_EQ(ws_connect(ws, with_token("/ws")), "");
  ASSERT_TRUE(run_until(io, [&] { return echo->opened == 1; }));
  auto& hub = server->samples();
  const auto id = hub.add_topic("/world/door", {"door_angle", "handle_angle"});
  echo->last->subscribe(id, 1000);
  for (int i = 0; i < 10; i++) {
    const double v[2] = {0.5 * i, 1.0};
    hub.publish(id, i * 1000000, v);
  }
  const std::string text = ws_read(ws);
  dca::wire::Value msg;
  std::string error;
  ASSERT_TRUE(dca::json::decode(text, &msg, &error)) << error << ": " << text;
  EXPECT_EQ(msg["type"].as_string(), "samples");
  EXPECT_EQ(msg["name"].as_string(), "/world/door");
  ASSERT_GE(msg["rows"].as_array().size(), 1u);
  EXPECT_EQ(msg["rows"].as_array()[0].as_array().size(), 3u);  // t, door_angle, handle_angle
  EXPECT_LE(msg["rows"].as_array().size(), 10u);
  EXPECT_EQ(hub.topic(id)->samples, 10u);
}

// A subscription's rate holds samples back, but never the newest for good: it goes once the interval has passed,
// or at once on flush_samples() (a run's end: the plots reach it; before, a run ending between two kept samples
// lost its last ones). Here the interval (1,000 s) never passes.
TEST_F(WebServerTest, TheNewestSampleARateHeldBackIsSentAtAFinalFlush) {
  websocket::stream<beast::tcp_stream> ws(io);
  ASSERT_EQ(ws_connect(ws, with_token("/ws")), "");
  ASSERT_TRUE(run_until(io, [&] { return echo->opened == 1; }));
  auto& hub = server->samples();
  const auto id = hub.add_topic("/main/a/Out", {"value"});
  echo->last->subscribe(id, 0.001);
  for (int i = 0; i < 10; i++) {
    const double v[1] = {0.5 * i};
    hub.publish(id, i * 1000000, v);
  }
  const auto rows = [&] {
    dca::wire::Value msg;
    std::string error;
    const std::string text = ws_read(ws);
    EXPECT_TRUE(dca::json::decode(text, &msg, &error)) << error << ": " << text;
    return msg["rows"];
  };
  const auto first = rows();
  ASSERT_EQ(first.as_array().size(), 1u) << "the rate keeps one";
  EXPECT_EQ(first.as_array()[0].as_array()[1].as_float(), 0.0);
  server->flush_samples();
  const auto last = rows();
  ASSERT_EQ(last.as_array().size(), 1u) << "the newest held back, once";
  EXPECT_EQ(last.as_array()[0].as_array()[0].as_float(), 0.009);
  EXPECT_EQ(last.as_array()[0].as_array()[1].as_float(), 4.5);
}

TEST(WebTextTest, TheKeyTokenIsAKeyedHashNotTheKey) {
  const std::string key(32, 'k');
  const std::string t = dca::web::key_token(key);
  EXPECT_EQ(t.size(), 32u);
  EXPECT_EQ(t, dca::web::key_token(key));
  EXPECT_NE(t, dca::web::key_token(std::string(32, 'j')));
  EXPECT_EQ(t.find_first_not_of("0123456789abcdef"), std::string::npos);
  EXPECT_NE(dca::web::random_token(), dca::web::random_token());
}

TEST(WebTextTest, QueryValuesAreFoundAndDecoded) {
  EXPECT_EQ(dca::web::query_value("/ws?token=ab%20c&x=1", "token"), "ab c");
  EXPECT_EQ(dca::web::query_value("/ws?x=1&token=z", "token"), "z");
  EXPECT_EQ(dca::web::query_value("/ws?tokens=1", "token"), "");
  EXPECT_EQ(dca::web::query_value("/ws", "token"), "");
  EXPECT_EQ(dca::web::query_value("/ws?token=%", "token"), "%");
}

}  // namespace
