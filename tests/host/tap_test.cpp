// Taps (host/net/tap.h): stamped links from any output to tap inputs, in process and over an authenticated socket;
// the tap inputs' bounded queues (drop-oldest, counted); a TapPoint's drain; the JSON of samples and schemas.
#include "host/net/tap.h"

#include <gtest/gtest.h>


#include <array>
#include <chrono>
#include <cmath>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <boost/asio/io_context.hpp>

#include <dca/msgs_cdr.h>
#include "host/codec/data_frame.h"
#include "tests/support/run_until.h"

namespace {

using dca::test::run_until;
namespace tap = dca::tap;

const dca::auth::Key kKey = "0123456789abcdef0123456789abcdef";

dca::EndpointOptions keyed() {
  dca::EndpointOptions o;
  o.key = kKey;
  return o;
}

struct Got {
  std::string path;
  std::int64_t t;
  std::string json;
};

class TapTest : public ::testing::Test {
 protected:
  std::string connect(dca::Endpoint& ep, const dca::ConnectRequest& r, const dca::Location& dest) {
    std::optional<std::string> result;
    ep.connect(r, dest, [&](const std::string& e) { result = e; }, 2000);
    EXPECT_TRUE(run_until(io, [&] { return result.has_value(); })) << "connect never answered";
    return result.value_or("no answer");
  }
  // The tap's link of `from`.`out` to component `to`, as the supervisor asks for it (dca.supervisor.taps).
  static dca::ConnectRequest tap_link(const std::string& from, const std::string& out, const std::string& to) {
    dca::ConnectRequest r{from, out, to, tap::input_name(from + "." + out), tap::input_name(from + "." + out),
                          dca::Mode::Push, 16};
    r.stamped = true;
    return r;
  }
  tap::Taps::Sink collect() {
    return [this](tap::Taps::Tap& t, std::int64_t at, dca::Bytes sample) {
      got.push_back({t.path, at, tap::sample_json(t.spec, sample)});
    };
  }
  boost::asio::io_context io;
  std::int64_t now = 0;  // the writers' clock
  std::vector<Got> got;
};

TEST_F(TapTest, AStampedInProcessLinkCarriesTheWritersTimeAndTheOutputKeepsItsOwnLinks) {
  dca::Endpoint ep(io, "a");
  ep.set_clock([this] { return now; });
  dca::PortSet src, dst, taps_ports;
  auto& out = src.add_output(dca::vector_port("Vel", 3, "m/s"));
  auto& in = dst.add_input(dca::vector_port("In", 3), 16);
  tap::Taps taps(taps_ports);
  std::string error;
  ASSERT_NE(taps.add("main.a.Vel", out.spec(), 8, &error), nullptr) << error;
  ep.add_component("main.a", src);
  ep.add_component("main.b", dst);
  ep.add_component("taps", taps_ports);
  ASSERT_EQ(connect(ep, {"main.a", "Vel", "main.b", "In", "s", dca::Mode::Push, 16}, {}), "");
  ASSERT_EQ(connect(ep, tap_link("main.a", "Vel", "taps"), {}), "");
  ep.activate("s");
  ep.activate(tap::input_name("main.a.Vel"));
  const auto digest0 = out.digest();
  now = 10'000'000;
  out.write(Eigen::Vector3d(1, 2, 3));
  now = 20'000'000;
  out.write(Eigen::Vector3d(4, 5, 6));
  taps.drain(collect());
  ASSERT_EQ(got.size(), 2u);
  EXPECT_EQ(got[0].t, 10'000'000);
  EXPECT_EQ(got[0].json, "{\"value\":[1,2,3]}");
  EXPECT_EQ(got[1].t, 20'000'000);
  EXPECT_EQ(got[1].json, "{\"value\":[4,5,6]}");
  // the writer's own reader gets the samples as they were, and the output counts them once
  ASSERT_TRUE(in.pop());
  EXPECT_EQ(in.vector()[2], 3.0);
  EXPECT_EQ(out.stats().samples, 2u);
  EXPECT_NE(out.digest(), digest0);
}

TEST_F(TapTest, OnlyATapInputTakesAStampedLinkAndATapInputTakesAnyType) {
  dca::Endpoint ep(io, "a");
  dca::PortSet src, dst, taps_ports;
  src.add_output(dca::scalar_port("Out"));
  dst.add_input(dca::value_port("Plain"), 4);
  tap::Taps taps(taps_ports);
  std::string error;
  ASSERT_NE(taps.add("main.a.Out", dca::scalar_port("Out"), 4, &error), nullptr);
  ep.add_component("main.a", src);
  ep.add_component("main.b", dst);
  ep.add_component("taps", taps_ports);
  auto r = tap_link("main.a", "Out", "main.b");
  r.in = "Plain";
  EXPECT_NE(connect(ep, r, {}).find("tap input"), std::string::npos);
  // and an unstamped link of a scalar to the tap input is a type mismatch, as to any value input
  dca::ConnectRequest plain{"main.a", "Out", "taps", tap::input_name("main.a.Out"), "s", dca::Mode::Push, 4};
  EXPECT_NE(connect(ep, plain, {}), "");
  EXPECT_EQ(connect(ep, tap_link("main.a", "Out", "taps"), {}), "");
}

TEST_F(TapTest, ASlowTapKeepsTheNewestSamplesAndCountsTheDropped) {
  dca::Endpoint ep(io, "a");
  dca::PortSet src, taps_ports;
  auto& out = src.add_output(dca::scalar_port("Out"));
  tap::Taps taps(taps_ports);
  std::string error;
  auto* t = taps.add("main.a.Out", out.spec(), 4, &error);
  ASSERT_NE(t, nullptr);
  ep.add_component("main.a", src);
  ep.add_component("taps", taps_ports);
  auto r = tap_link("main.a", "Out", "taps");
  r.queue = 4;  // the input holds the most any of its links asks for
  ASSERT_EQ(connect(ep, r, {}), "");
  ep.activate(tap::input_name("main.a.Out"));
  for (int i = 0; i < 10; ++i) out.write(static_cast<double>(i));  // nobody drains: the writer never waits
  EXPECT_EQ(out.stats().samples, 10u);
  EXPECT_EQ(t->dropped(), 6u);
  taps.drain(collect());
  ASSERT_EQ(got.size(), 4u);
  EXPECT_EQ(got.front().json, "{\"value\":6}");
  EXPECT_EQ(got.back().json, "{\"value\":9}");
  EXPECT_EQ(t->taken, 4u);
}

TEST_F(TapTest, ATapPointTakesStampedSamplesOverAnAuthenticatedSocket) {
  for (const bool tcp : {false, true}) {
    SCOPED_TRACE(tcp ? "tcp" : "unix");
    got.clear();
    dca::Endpoint writer(io, "a", keyed());
    writer.listen(dca::test::temp_socket("tap", tcp ? "w-tcp" : "w-uds"), "127.0.0.1:0");
    writer.set_clock([this] { return now; });
    dca::PortSet src;
    auto& out = src.add_output(dca::value_port("Event"));
    writer.add_component("main.a", src);
    tap::TapPoint point(io, tcp ? "b" : "a", "taps:main@1", keyed(), dca::test::temp_socket("tap", tcp ? "p-tcp" : "p-uds"));
    std::string error;
    ASSERT_NE(point.add("main.a.Event", out.spec(), 16, &error), nullptr) << error;
    point.on_sample = collect();
    ASSERT_EQ(connect(writer, tap_link("main.a", "Event", "taps:main@1"), point.location()), "");
    writer.activate(tap::input_name("main.a.Event"));
    now = 42;
    out.write_value(std::map<std::string, int>{{"n", 7}});
    ASSERT_TRUE(run_until(io, [&] { return got.size() == 1; }));
    EXPECT_EQ(got[0].path, "main.a.Event");
    EXPECT_EQ(got[0].t, 42);
    EXPECT_EQ(got[0].json, "{\"value\":{\"n\":7}}");
    // the tap's link is one of the writer's links, counted like any other
    EXPECT_EQ(writer.links().at(0).sent, 1u);
    EXPECT_EQ(writer.links().at(0).transport, tcp ? dca::Transport::Tcp : dca::Transport::Unix);
  }
}

// A tap point that takes nothing in for a while (its loop busy elsewhere): the writer's writes all return, the
// socket's backlog drops beyond its limit at the writer (counted), the tap input keeps its newest (counted);
// every sample is accounted for.
TEST_F(TapTest, ASlowTapPointNeverBlocksTheWriterAndCountsWhatItLoses) {
  dca::Endpoint writer(io, "a", keyed());
  writer.listen(dca::test::temp_socket("tap", "slow-w"), "127.0.0.1:0");
  dca::PortSet src;
  auto& out = src.add_output(dca::vector_port("Big", 128));
  writer.add_component("main.a", src);
  tap::TapPoint point(io, "a", "taps:slow", keyed(), dca::test::temp_socket("tap", "slow-p"));
  std::string error;
  auto* t = point.add("main.a.Big", out.spec(), 64, &error);
  ASSERT_NE(t, nullptr) << error;
  std::uint64_t got_n = 0;
  point.on_sample = [&](tap::Taps::Tap&, std::int64_t, dca::Bytes) { ++got_n; };
  auto r = tap_link("main.a", "Big", "taps:slow");
  r.queue = 64;
  ASSERT_EQ(connect(writer, r, point.location()), "");
  writer.activate(tap::input_name("main.a.Big"));
  constexpr int kWrites = 20000;  // 20,000 x 1 KiB: more than the socket's buffers and the 8 MiB backlog
  const Eigen::VectorXd v = Eigen::VectorXd::Ones(128);
  for (int i = 0; i < kWrites; ++i) out.write(v);  // the loop does not run: nobody takes anything in
  const auto link = writer.links().at(0);
  EXPECT_GT(link.tx_dropped, 0u);
  EXPECT_EQ(link.sent + link.tx_dropped, static_cast<std::uint64_t>(kWrites));
  ASSERT_TRUE(run_until(io, [&] { return t->input->stats().samples == link.sent && t->input->queued() == 0; },
                        std::chrono::seconds(20)));
  EXPECT_EQ(got_n + t->dropped(), link.sent);
  EXPECT_EQ(got_n, t->taken);
}

TEST_F(TapTest, AStampedHelloRoundTripsAndAnOldHelloIsUnstamped) {
  dca::data_frame::Hello h;
  h.request = tap_link("main.a", "Out", "taps");
  h.out = dca::scalar_port("Out");
  const std::string body = dca::data_frame::encode_hello(h);
  dca::data_frame::Hello back;
  std::string error;
  ASSERT_TRUE(dca::data_frame::decode_hello({reinterpret_cast<const std::byte*>(body.data()), body.size()}, back, &error));
  EXPECT_TRUE(back.request.stamped);
  h.request.stamped = false;
  const std::string plain = dca::data_frame::encode_hello(h);
  dca::data_frame::Hello old;
  ASSERT_TRUE(dca::data_frame::decode_hello({reinterpret_cast<const std::byte*>(plain.data()), plain.size()}, old, &error));
  EXPECT_FALSE(old.request.stamped);
}

TEST(TapJson, SamplesSchemasTopicsAndMalformedStamps) {
  EXPECT_EQ(tap::topic_of("main.door.hit.Force"), "/main/door/hit/Force");
  const double nan = std::nan("");
  EXPECT_EQ(tap::sample_json(dca::scalar_port("x"), {reinterpret_cast<const std::byte*>(&nan), sizeof nan}),
            "{\"value\":null}");
  EXPECT_EQ(tap::sample_json(dca::vector_port("x", 2), {}), "{\"value\":null}");  // wrong size
  const std::string junk = "\xc1";  // never valid msgpack
  EXPECT_EQ(tap::sample_json(dca::value_port("x"), {reinterpret_cast<const std::byte*>(junk.data()), 1}),
            "{\"value\":null}");
  // a Value's strings and keys as valid UTF-8 whatever their bytes (host/json's escaper: a bad byte is U+FFFD)
  const std::string str = "\xa3\xff\x01\"";        // msgpack: the 3-byte string FF 01 '"'
  EXPECT_EQ(tap::sample_json(dca::value_port("x"), {reinterpret_cast<const std::byte*>(str.data()), str.size()}),
            "{\"value\":\"\xef\xbf\xbd\\u0001\\\"\"}");
  const std::string map = "\x81\xa1\xc0\xcb\x3f\xb9\x99\x99\x99\x99\x99\x9a";  // {"\xc0": 0.1}
  EXPECT_EQ(tap::sample_json(dca::value_port("x"), {reinterpret_cast<const std::byte*>(map.data()), map.size()}),
            "{\"value\":{\"\xef\xbf\xbd\":0.1}}");
  EXPECT_EQ(tap::json_schema("/a", dca::vector_port("v", 2, "m")),
            "{\"type\":\"object\",\"title\":\"/a\",\"properties\":{\"value\":{\"type\":\"array\",\"items\":"
            "{\"type\":\"number\",\"description\":\"m\"},\"minItems\":2,\"maxItems\":2}}}");
  // a message port: its fields by name, and its type's schema (docs/data-plane.md, "Typed messages")
  const auto twist = dca::message_port("cmd", "geometry_msgs/msg/Twist");
  const dca::msgs::Twist tw{{1, 0.5, 0}, {0, 0, -2}};
  std::array<std::byte, dca::msgs::cdr_max_size<dca::msgs::Twist>> buf{};
  const dca::Bytes cdr(buf.data(), dca::msgs::cdr_encode(tw, buf));
  EXPECT_EQ(tap::sample_json(twist, cdr),
            R"({"value":{"linear":{"x":1,"y":0.5,"z":0},"angular":{"x":0,"y":0,"z":-2}}})");
  EXPECT_EQ(tap::sample_json(twist, cdr.first(10)), "{\"value\":null}");
  const std::string xyz = R"({"type":"object","title":"geometry_msgs/msg/Vector3","properties":{"x":{"type":"number"},)"
                          R"("y":{"type":"number"},"z":{"type":"number"}}})";
  EXPECT_EQ(tap::json_schema("/cmd", twist),
            R"({"type":"object","title":"/cmd","properties":{"value":{"type":"object","title":"geometry_msgs/msg/Twist",)"
            R"("properties":{"linear":)" + xyz + ",\"angular\":" + xyz + "}}}}");
  std::vector<double> values;
  EXPECT_FALSE(tap::sample_values(twist, cdr, values));
  std::int64_t t = 0;
  dca::Bytes sample;
  const char three[3] = {1, 2, 3};
  EXPECT_FALSE(tap::unstamp({reinterpret_cast<const std::byte*>(three), 3}, t, sample));
}

}  // namespace
