// Data frames (pure): the frame parser (with its link id), the Hello and Peer codecs.
#include "host/codec/data_frame.h"

#include "host/codec/wire.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace {

namespace df = dca::data_frame;

TEST(DataFrameTest, FrameParserRejectsBadFrames) {
  using df::Parse;
  std::vector<std::byte> buf(df::kHeader + 3);
  df::put_header(buf.data(), df::Kind::Sample, 0x01020304u, 3);
  df::Frame f;
  std::size_t used = 0;
  std::string err;
  EXPECT_EQ(df::parse_frame(buf, f, used, &err), Parse::Ok);
  EXPECT_EQ(used, buf.size());
  EXPECT_EQ(f.body.size(), 3u);
  EXPECT_EQ(f.kind, df::Kind::Sample);
  EXPECT_EQ(f.link, 0x01020304u) << "every frame names its link";
  for (std::size_t n = 0; n < buf.size(); ++n)  // every truncation asks for more
    EXPECT_EQ(df::parse_frame({buf.data(), n}, f, used, &err), Parse::NeedMore) << n;
  buf[4] = std::byte{99};
  EXPECT_EQ(df::parse_frame(buf, f, used, &err), Parse::Error);
  EXPECT_EQ(err, "unknown data frame kind 99");
  std::vector<std::byte> big(df::kHeader);
  df::put_header(big.data(), df::Kind::Sample, 1, df::kMaxFrame);
  EXPECT_EQ(df::parse_frame(big, f, used, &err), Parse::Error);
  std::vector<std::byte> empty(4, std::byte{0});
  EXPECT_EQ(df::parse_frame(empty, f, used, &err), Parse::Error);
  std::vector<std::byte> no_link{std::byte{0}, std::byte{0}, std::byte{0}, std::byte{1}, std::byte{4}};
  EXPECT_EQ(df::parse_frame(no_link, f, used, &err), Parse::Error);
  EXPECT_EQ(err, "data frame of 1 bytes has no kind and link");
}

TEST(DataFrameTest, PeerRoundTripsAndRejectsGarbage) {
  const dca::Location self{"h1", "/run/dca/n.sock", "127.0.0.1:4000"};
  const auto body = df::encode_peer(self);
  dca::Location back;
  std::string err;
  ASSERT_TRUE(df::decode_peer({reinterpret_cast<const std::byte*>(body.data()), body.size()}, back, &err)) << err;
  EXPECT_EQ(back.host, "h1");
  EXPECT_EQ(back.data_uds, "/run/dca/n.sock");
  EXPECT_EQ(back.data_tcp, "127.0.0.1:4000");
  const auto refused = [](dca::wire::Value v) {
    std::string b, e;
    dca::wire::encode_value(v, b);
    dca::Location l;
    EXPECT_FALSE(df::decode_peer({reinterpret_cast<const std::byte*>(b.data()), b.size()}, l, &e));
    return e;
  };
  EXPECT_EQ(refused(dca::wire::Value::map().set("tcp", std::int64_t{3})), "peer: 'tcp' is not a string");
  EXPECT_EQ(refused(dca::wire::Value::map().set("uds", std::string(300, 'x'))), "peer: 'uds' is too long");
  EXPECT_EQ(refused(dca::wire::Value::map().set("host", "a\nb")), "peer: 'host' holds a control character");
  EXPECT_EQ(refused(dca::wire::Value(std::int64_t{1})), "peer introduction is not a map");
}

TEST(DataFrameTest, HelloRoundTripsAndRejectsGarbage) {
  df::Hello h{{"/a", "Out", "/b", "In", "g:x[l]", dca::Mode::Pull, 7}, dca::vector_port("Out", 8)};
  const auto body = df::encode_hello(h);
  df::Hello back;
  std::string err;
  ASSERT_TRUE(df::decode_hello({reinterpret_cast<const std::byte*>(body.data()), body.size()}, back, &err)) << err;
  EXPECT_EQ(back.request.to, "/b");
  EXPECT_EQ(back.request.set, "g:x[l]");
  EXPECT_EQ(back.request.mode, dca::Mode::Pull);
  EXPECT_EQ(back.request.queue, 7u);
  EXPECT_EQ(back.out.type, dca::PortType::Vector);
  EXPECT_EQ(back.out.size, 8u);
  const std::string junk = "\x93\x01\x02";
  EXPECT_FALSE(df::decode_hello({reinterpret_cast<const std::byte*>(junk.data()), junk.size()}, back, &err));
  EXPECT_FALSE(err.empty());
  // a message port's type travels with it, so the destination holds it to its input's (compatibility_error)
  const df::Hello m{{"/a", "Cmd", "/b", "CmdVel", "s"}, dca::message_port("Cmd", "geometry_msgs/msg/Twist")};
  const auto mb = df::encode_hello(m);
  df::Hello mback;
  ASSERT_TRUE(df::decode_hello({reinterpret_cast<const std::byte*>(mb.data()), mb.size()}, mback, &err)) << err;
  EXPECT_EQ(mback.out.type, dca::PortType::Message);
  EXPECT_EQ(mback.out.message, "geometry_msgs/msg/Twist");
  EXPECT_EQ(dca::compatibility_error(mback.out, dca::message_port("CmdVel", "geometry_msgs/msg/Twist")), "");
  // the sender's id and serial (a moved link's two hellos told apart); a hello without them reads 0, 0
  df::Hello s{{"/a", "Out", "/b", "In", "s"}, dca::vector_port("Out", 2)};
  s.sender = df::kMaxSerial;
  s.serial = 5;
  const auto sb = df::encode_hello(s);
  df::Hello sback;
  ASSERT_TRUE(df::decode_hello({reinterpret_cast<const std::byte*>(sb.data()), sb.size()}, sback, &err)) << err;
  EXPECT_EQ(sback.sender, df::kMaxSerial);
  EXPECT_EQ(sback.serial, 5u);
  EXPECT_EQ(back.sender, 0u);
  EXPECT_EQ(back.serial, 0u);
}

// Regression: a hello with queue = 4294967295 made the destination allocate the queue and die of bad_alloc.
TEST(DataFrameTest, HostileHelloFieldsAreRefusedWithTheirName) {
  const auto refused = [](dca::wire::Value v) {
    std::string body, err;
    dca::wire::encode_value(v, body);
    df::Hello h;
    EXPECT_FALSE(df::decode_hello({reinterpret_cast<const std::byte*>(body.data()), body.size()}, h, &err));
    return err;
  };
  const auto hello = [] {
    return dca::wire::Value::map().set("from", "/a").set("out", "Out").set("to", "/b").set("in", "In")
        .set("set", "s").set("type", "vector").set("size", std::int64_t{3});
  };
  EXPECT_EQ(refused(hello().set("queue", std::int64_t{4294967295})), "hello: 'queue' is 4294967295 (at most 4096)");
  EXPECT_EQ(refused(hello().set("queue", std::int64_t{-1})), "hello: 'queue' is not a count");
  EXPECT_EQ(refused(hello().set("size", std::int64_t{1} << 40)), "hello: 'size' is 1099511627776 (at most 65536)");
  EXPECT_EQ(refused(hello().set("in", std::string(300, 'x'))), "hello: 'in' is 300 bytes (at most 256)");
  EXPECT_EQ(refused(hello().set("to", std::string("/b\0x", 4))), "hello: 'to' holds a control character");
  EXPECT_EQ(refused(hello().set("set", "a\nb")), "hello: 'set' holds a control character");
  EXPECT_EQ(refused(hello().set("to", "")), "hello: no destination named");
  EXPECT_EQ(refused(hello().set("serial", std::int64_t{-2})), "hello: 'serial' is not a count");
  EXPECT_EQ(refused(hello().set("sender", "me")), "hello: 'sender' is not a count");
  std::string body, err;
  dca::wire::encode_value(hello().set("queue", std::int64_t{df::kMaxQueue}), body);
  df::Hello h;
  EXPECT_TRUE(df::decode_hello({reinterpret_cast<const std::byte*>(body.data()), body.size()}, h, &err)) << err;
  EXPECT_EQ(h.request.queue, df::kMaxQueue);
}

}  // namespace
