// The Foxglove WebSocket protocol (host/web/foxglove.h) on a fake connection: serverInfo and advertise at open, JSON
// Schemas and messages from a topic's fields, subscribe/unsubscribe (first and last told), binary Message Data
// (subscription id, timestamp, payload; little-endian), malformed and unknown requests answered with a status, a
// removed topic's subscriptions ended (the last one told, once); link frames as foxglove.FrameTransforms and the URDF
// sent at subscribe.
#include "host/web/foxglove.h"

#include <gtest/gtest.h>

#include <boost/asio/io_context.hpp>

#include "host/codec/json.h"
#include "host/net/tap.h"

namespace {

class FakeConnection : public dca::web::Connection {
 public:
  bool send(std::string data, bool binary, bool) override {
    (binary ? frames : texts).push_back(std::move(data));
    return true;
  }
  void close(const std::string&) override {}
  bool is_open() const override { return true; }
  void subscribe(std::uint32_t, double) override {}
  std::uint64_t id() const override { return conn_id; }
  const std::string& protocol() const override { return proto; }
  const std::string& peer() const override { return proto; }
  dca::web::ConnectionStats stats() const override { return {}; }
  std::string proto = "foxglove.websocket.v1";
  std::uint64_t conn_id = 1;
  std::vector<std::string> texts, frames;
};

dca::wire::Value decoded(const std::string& text) {
  dca::wire::Value v;
  std::string error;
  EXPECT_TRUE(dca::json::decode(text, &v, &error)) << error;
  return v;
}

// A server on a free loopback port, whose sample hub the tests fill.
class FoxgloveServer : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string error;
    server = dca::web::Server::listen(io, *dca::Address::parse("127.0.0.1:0"), {}, &error);
    ASSERT_TRUE(server) << error;
  }
  boost::asio::io_context io;
  std::shared_ptr<dca::web::Server> server;
  dca::SampleHub& hub() { return server->samples(); }
};

TEST(Foxglove, SchemasAndMessagesFollowTheTopicsFields) {
  dca::SampleHub::Topic vec, door, any;
  vec.id = 1, vec.name = "/main/a/Vel", vec.fields = {"value[0]", "value[1]"};
  door.id = 2, door.name = "/world/door", door.fields = {"door_angle", "handle_angle"};
  any.id = 3, any.name = "/main/a/X";
  EXPECT_EQ(dca::foxglove::schema_of(vec),
            "{\"type\":\"object\",\"title\":\"/main/a/Vel\",\"properties\":{\"value\":{\"type\":\"array\",\"items\":"
            "{\"type\":\"number\"},\"minItems\":2,\"maxItems\":2}}}");
  // named and described as a recording's channel of the same port (tap::json_schema, sim/recorder.h)
  EXPECT_EQ(dca::foxglove::schema_name_of(vec), "main/a/Vel");
  vec.units = "m/s, rad/s";
  const dca::PortSpec port{"a.Vel", dca::PortType::Vector, 2, "m/s, rad/s", {}};
  EXPECT_EQ(dca::foxglove::schema_of(vec), dca::tap::json_schema("/main/a/Vel", port));
  any.units = "m";
  EXPECT_EQ(dca::foxglove::schema_of(any), dca::tap::json_schema("/main/a/X", {"a.X", dca::PortType::VectorX, 0, "m", {}}));
  vec.units.clear();
  const double v[] = {1.5, -2};
  EXPECT_EQ(dca::foxglove::message_of(vec, 0, v), "{\"value\":[1.5,-2]}");
  EXPECT_EQ(dca::foxglove::message_of(door, 0, v), "{\"door_angle\":1.5,\"handle_angle\":-2}");
  EXPECT_EQ(dca::foxglove::message_of(any, 0, v), "{\"value\":[1.5,-2]}");
}

TEST_F(FoxgloveServer, SubscribersGetMessageDataAndBadRequestsAStatus) {
  const auto id = hub().add_topic("/main/a/Out", {"value"});
  dca::foxglove::Protocol p(server, "dca main");
  std::vector<std::string> first, last;
  p.on_first_subscribe = [&](const std::string& t) { first.push_back(t); };
  p.on_last_unsubscribe = [&](const std::string& t) { last.push_back(t); };
  auto c = std::make_shared<FakeConnection>();
  p.on_open(c);
  ASSERT_EQ(c->texts.size(), 2u);
  EXPECT_EQ(decoded(c->texts[0])["op"].as_string(), "serverInfo");
  const auto adv = decoded(c->texts[1]);
  EXPECT_EQ(adv["op"].as_string(), "advertise");
  EXPECT_EQ(adv["channels"].as_array().at(0)["topic"].as_string(), "/main/a/Out");
  EXPECT_EQ(adv["channels"].as_array().at(0)["schemaEncoding"].as_string(), "jsonschema");

  p.on_message(c, "{\"op\":\"subscribe\",\"subscriptions\":[{\"id\":7,\"channelId\":" + std::to_string(id) + "}]}", false);
  EXPECT_EQ(first, std::vector<std::string>{"/main/a/Out"});
  const double x = 0.25;
  hub().publish(id, 0x0102030405060708, {&x, 1});
  ASSERT_EQ(c->frames.size(), 1u);
  const std::string& f = c->frames[0];
  EXPECT_EQ(f[0], 1);
  EXPECT_EQ(std::string(f.data() + 1, 4), std::string("\x07\0\0\0", 4));
  EXPECT_EQ(std::string(f.data() + 5, 8), std::string("\x08\x07\x06\x05\x04\x03\x02\x01", 8));
  EXPECT_EQ(f.substr(13), "{\"value\":0.25}");

  const auto before = c->texts.size();
  p.on_message(c, "not json", false);
  p.on_message(c, "{\"op\":\"setParameters\"}", false);
  p.on_message(c, "\x01\x02", true);
  p.on_message(c, "{\"op\":\"subscribe\",\"subscriptions\":[{\"id\":8,\"channelId\":999}]}", false);
  ASSERT_EQ(c->texts.size(), before + 4);
  for (std::size_t i = before; i < c->texts.size(); ++i) EXPECT_EQ(decoded(c->texts[i])["op"].as_string(), "status");

  p.on_message(c, "{\"op\":\"unsubscribe\",\"subscriptionIds\":[7]}", false);
  EXPECT_EQ(last, std::vector<std::string>{"/main/a/Out"});
  hub().publish(id, 2, {&x, 1});
  EXPECT_EQ(c->frames.size(), 1u);
  p.on_close(c, "bye");
  server->close();
}

std::string subscribe(std::uint32_t sub, std::uint32_t channel) {
  return "{\"op\":\"subscribe\",\"subscriptions\":[{\"id\":" + std::to_string(sub) +
         ",\"channelId\":" + std::to_string(channel) + "}]}";
}

// A topic removed while subscribed (by two clients): its subscriptions end with it, so the run
// is told its last one went (its tap can go) exactly once; the other topic's subscription stays; the topic made
// again is a new channel whose first subscriber is told again.
TEST_F(FoxgloveServer, ARemovedTopicEndsItsSubscriptionsAndTellsTheLastOnce) {
  const auto gone = hub().add_topic("/main/a/Out", {"value"});
  const auto stays = hub().add_topic("/main/b/Out", {"value"});
  dca::foxglove::Protocol p(server, "dca main");
  std::vector<std::string> first, last;
  p.on_first_subscribe = [&](const std::string& t) { first.push_back(t); };
  p.on_last_unsubscribe = [&](const std::string& t) { last.push_back(t); };
  auto a = std::make_shared<FakeConnection>(), b = std::make_shared<FakeConnection>();
  b->conn_id = 2;
  p.on_open(a);
  p.on_open(b);
  p.on_message(a, subscribe(1, gone), false);
  p.on_message(b, subscribe(1, gone), false);
  p.on_message(b, subscribe(2, stays), false);
  EXPECT_EQ(first, (std::vector<std::string>{"/main/a/Out", "/main/b/Out"}));

  hub().remove_topic(gone);
  EXPECT_EQ(last, std::vector<std::string>{"/main/a/Out"});
  for (const auto& c : {a, b}) {
    const auto m = decoded(c->texts.back());
    EXPECT_EQ(m["op"].as_string(), "unadvertise");
    EXPECT_EQ(m["channelIds"].as_array().at(0).as_int(), gone);
  }
  p.on_message(a, "{\"op\":\"unsubscribe\",\"subscriptionIds\":[1]}", false);
  EXPECT_EQ(last.size(), 1u) << "an ended subscription is not ended twice";
  const double x = 1;
  hub().publish(stays, 5, {&x, 1});
  EXPECT_EQ(b->frames.size(), 1u);
  EXPECT_TRUE(a->frames.empty());

  const auto again = hub().add_topic("/main/a/Out", {"value"});
  EXPECT_NE(again, gone);
  p.on_message(a, subscribe(3, again), false);
  EXPECT_EQ(first, (std::vector<std::string>{"/main/a/Out", "/main/b/Out", "/main/a/Out"}));
  p.on_close(a, "bye");
  p.on_close(b, "bye");
  EXPECT_EQ(last, (std::vector<std::string>{"/main/a/Out", "/main/a/Out", "/main/b/Out"}));
  server->close();
}

// Time (opcode 2) in simulated time: sent at a client's open, on the run's time (forced) and on a sample 10 ms or
// more past the last Time; never backwards; after the run's end (end_time) neither a sample of the shutdown nor
// the world stepping on moves it (a CI run's Foxglove clock showed 38.9 s for a run of 1 s).
TEST_F(FoxgloveServer, TimeFollowsTheRunAndStopsAtItsEnd) {
  const auto topic = hub().add_topic("/main/a/Out", {"value"});
  dca::foxglove::Protocol p(server, "dca main");
  p.sim_time = true;
  auto a = std::make_shared<FakeConnection>();
  p.on_open(a);
  EXPECT_NE(a->texts.at(0).find("\"time\""), std::string::npos) << a->texts.at(0);
  const auto times = [&] {
    std::vector<std::int64_t> out;
    for (const auto& f : a->frames) {
      if (f.size() != 9 || f[0] != 2) continue;
      std::uint64_t t = 0;
      for (int i = 0; i < 8; ++i) t |= static_cast<std::uint64_t>(static_cast<unsigned char>(f[1 + i])) << (8 * i);
      out.push_back(static_cast<std::int64_t>(t));
    }
    return out;
  };
  const double x = 1;
  p.time(100'000'000);
  hub().publish(topic, 105'000'000, {&x, 1});  // under 10 ms past: no Time
  hub().publish(topic, 120'000'000, {&x, 1});
  p.time(50'000'000);                           // backwards: nothing
  EXPECT_EQ(times(), (std::vector<std::int64_t>{100'000'000, 120'000'000}));
  p.end_time(1'000'000'000);
  p.time(38'899'000'000);
  hub().publish(topic, 2'000'000'000, {&x, 1});
  EXPECT_EQ(times(), (std::vector<std::int64_t>{100'000'000, 120'000'000, 1'000'000'000}));
  p.on_close(a, "bye");
  server->close();
}

// One request of 2,000 subscriptions to one channel (59 KB) made the server send every sample 2,000 times and
// answer nothing: a client now holds one subscription per channel, and the refused rest gets one status.
TEST_F(FoxgloveServer, OneChannelIsSubscribedOncePerClientAndRefusalsGetOneStatus) {
  const auto id = hub().add_topic("/main/a/Out", {"value"});
  dca::foxglove::Protocol p(server, "dca main");
  auto c = std::make_shared<FakeConnection>();
  p.on_open(c);
  std::string request = "{\"op\":\"subscribe\",\"subscriptions\":[";
  for (int i = 0; i < 2000; ++i)
    request += (i ? "," : "") + std::string("{\"id\":") + std::to_string(i) + ",\"channelId\":" + std::to_string(id) + "}";
  request += "]}";
  const auto texts = c->texts.size();
  p.on_message(c, request, false);
  ASSERT_EQ(c->texts.size(), texts + 1);
  const auto st = decoded(c->texts.back());
  EXPECT_EQ(st["op"].as_string(), "status");
  EXPECT_EQ(st["message"].as_string(), "subscribe: channel " + std::to_string(id) +
                                           " is subscribed already (and 1998 more refused)");
  const double x = 0.5;
  hub().publish(id, 1, {&x, 1});
  EXPECT_EQ(c->frames.size(), 1u);
  p.on_message(c, "{\"op\":\"unsubscribe\",\"subscriptionIds\":[0]}", false);
  p.on_message(c, subscribe(5, id), false);  // free again
  hub().publish(id, 2, {&x, 1});
  EXPECT_EQ(c->frames.size(), 2u);
  EXPECT_EQ(std::string(c->frames[1].data() + 1, 4), std::string("\x05\0\0\0", 4));
  p.on_close(c, "bye");
  server->close();
}

}  // namespace

// A URDF world's link frames are advertised as foxglove.FrameTransforms, each sample one message of every frame;
// the URDF's topic of one message (std_msgs/String) sends it to each subscriber as it subscribes.
TEST_F(FoxgloveServer, LinkFramesAreFrameTransformsAndTheUrdfComesAtSubscribe) {
  const auto tf = hub().add_topic("/world/links/frames", {});
  ASSERT_TRUE(hub().set_frames(tf, {{"world", "base"}, {"base", "arm"}}));
  const auto urdf = hub().add_message_topic("/robot_description", "std_msgs/String", "{\"type\":\"object\"}",
                                          "{\"data\":\"<robot name=\\\"r\\\"/>\"}");
  dca::foxglove::Protocol p(server, "dca main");
  auto c = std::make_shared<FakeConnection>();
  p.on_open(c);
  const auto adv = decoded(c->texts.at(1))["channels"].as_array();
  ASSERT_EQ(adv.size(), 2u);
  EXPECT_EQ(adv.at(0)["schemaName"].as_string(), "foxglove.FrameTransforms");
  EXPECT_EQ(adv.at(1)["schemaName"].as_string(), "std_msgs/String");
  EXPECT_EQ(decoded(adv.at(0)["schema"].as_string())["title"].as_string(), "foxglove.FrameTransforms");

  p.on_message(c, subscribe(1, urdf), false);
  ASSERT_EQ(c->frames.size(), 1u);
  EXPECT_EQ(decoded(c->frames[0].substr(13))["data"].as_string(), "<robot name=\"r\"/>");
  p.on_message(c, subscribe(2, tf), false);
  const double v[] = {1, 2, 3, 0, 0, 0, 1, 0.5, 0, 0, 0, 0, 0.6, 0.8};
  hub().publish(tf, 1500000000, {v, 14});
  ASSERT_EQ(c->frames.size(), 2u);
  const auto m = decoded(c->frames[1].substr(13));
  const auto& ts = m["transforms"].as_array();
  ASSERT_EQ(ts.size(), 2u);
  EXPECT_EQ(ts[0]["parent_frame_id"].as_string(), "world");
  EXPECT_EQ(ts[1]["child_frame_id"].as_string(), "arm");
  EXPECT_EQ(ts[1]["timestamp"]["sec"].as_int(), 1);
  EXPECT_EQ(ts[1]["timestamp"]["nsec"].as_int(), 500000000);
  EXPECT_DOUBLE_EQ(ts[0]["translation"]["z"].as_float(), 3);
  EXPECT_DOUBLE_EQ(ts[1]["rotation"]["w"].as_float(), 0.8);
  p.on_close(c, "bye");
  server->close();
}
