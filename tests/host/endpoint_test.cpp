// Endpoint: in-process / Unix-socket / TCP connections, push and pull, sets, overflow, broken links; socket
// connections authenticated with the cluster key, and their deadlines; one socket connection between two
// endpoints carrying their links both ways.
#include "host/net/endpoint.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <optional>
#include <string>
#include <vector>

#include <boost/asio/io_context.hpp>

#include <dca/msgs_cdr.h>
#include "host/codec/data_frame.h"
#include "tests/support/raw_data_client.h"
#include "tests/support/run_until.h"

namespace {

using namespace std::chrono_literals;
using dca::test::run_until;
namespace df = dca::data_frame;

const dca::auth::Key kKey = "0123456789abcdef0123456789abcdef";  // the cluster key of the endpoints under test
const dca::auth::Key kOtherKey = "fedcba9876543210fedcba9876543210";

dca::EndpointOptions keyed(dca::auth::Key key = kKey) {
  dca::EndpointOptions o;
  o.key = std::move(key);
  return o;
}

std::string temp_socket(const std::string& tag) { return dca::test::temp_socket("comms", tag); }

std::vector<double> drain(dca::Input& in) {
  std::vector<double> v;
  while (in.pop()) v.push_back(in.scalar());
  return v;
}

class EndpointTest : public ::testing::Test {
 protected:
  // Connects and waits for the answer; returns the error ("" on success).
  std::string connect(dca::Endpoint& ep, dca::ConnectRequest r, const dca::Location& dest) {
    std::optional<std::string> result;
    ep.connect(r, dest, [&](const std::string& e) { result = e; }, 2000);
    EXPECT_TRUE(run_until(io, [&] { return result.has_value(); })) << "connect never answered";
    return result.value_or("no answer");
  }
  static dca::ConnectRequest req(std::string from, std::string out, std::string to, std::string in, std::string set,
                                 dca::Mode mode = dca::Mode::Push, std::uint32_t queue = 16) {
    return {std::move(from), std::move(out), std::move(to), std::move(in), std::move(set), mode, queue};
  }
  boost::asio::io_context io;
};

// One endpoint holding /src (a scalar output Out) and /dst (a scalar input In).
class EndpointInProcessTest : public EndpointTest {
 protected:
  // Declares the ports (In with room for `queue` samples) and registers both components.
  void add_pair(std::size_t queue = 1) {
    output = &src.add_output(dca::scalar_port("Out"));
    input = &dst.add_input(dca::scalar_port("In"), queue);
    ep.add_component("/src", src);
    ep.add_component("/dst", dst);
  }
  dca::Endpoint ep{io, "a"};
  dca::PortSet src, dst;
  dca::Output* output = nullptr;
  dca::Input* input = nullptr;
};

TEST_F(EndpointInProcessTest, InProcessPushDeliversOnlyWhileTheSetIsActive) {
  add_pair();
  auto& out = *output;
  auto& in = *input;
  EXPECT_EQ(connect(ep, req("/src", "Out", "/dst", "In", "g:s[a]"), {}), "");
  ASSERT_EQ(ep.links().size(), 1u);
  EXPECT_EQ(ep.links()[0].transport, dca::Transport::InProcess);
  out.write(1.0);  // inactive: nothing arrives
  EXPECT_EQ(in.queued(), 0u);
  EXPECT_EQ(ep.links()[0].skipped, 1u);
  ep.activate("g:s[a]");
  out.write(2.0);
  out.write(3.0);
  ep.deactivate("g:s[a]");
  out.write(4.0);
  ep.activate("g:s[a]");
  out.write(5.0);
  EXPECT_EQ(drain(in), (std::vector<double>{2, 3, 5}));
}

TEST_F(EndpointInProcessTest, PushOverflowDropsTheOldestAndCountsIt) {
  std::vector<dca::CommsEvent> events;
  ep.on_event([&](const dca::CommsEvent& e) { events.push_back(e); });
  add_pair(1);
  auto& out = *output;
  auto& in = *input;
  ASSERT_EQ(connect(ep, req("/src", "Out", "/dst", "In", "s", dca::Mode::Push, 4), {}), "");
  ep.activate("s");
  for (int i = 1; i <= 10; ++i) out.write(static_cast<double>(i));
  EXPECT_EQ(in.stats().dropped, 6u);
  EXPECT_EQ(in.stats().samples, 10u);
  EXPECT_EQ(drain(in), (std::vector<double>{7, 8, 9, 10}));
  ASSERT_EQ(events.size(), 1u);  // reported once, counted always
  EXPECT_EQ(events[0].kind, dca::CommsEvent::Kind::Overflow);
  EXPECT_EQ(events[0].component, "/dst");
}

TEST_F(EndpointInProcessTest, InProcessPullGivesTheLatestSampleOnRequest) {
  add_pair();
  auto& out = *output;
  auto& in = *input;
  ASSERT_EQ(connect(ep, req("/src", "Out", "/dst", "In", "s", dca::Mode::Pull), {}), "");
  ep.activate("s");
  out.write(1.0);
  out.write(2.0);
  out.write(3.0);
  EXPECT_EQ(in.queued(), 0u);  // pull: nothing pushed
  EXPECT_FALSE(in.has_current());
  in.request();
  EXPECT_EQ(in.scalar(), 3.0);
}

TEST_F(EndpointTest, FanOutAndFanIn) {
  dca::Endpoint ep(io, "a");
  dca::PortSet a, b, c, d;
  auto& outa = a.add_output(dca::scalar_port("Out"));
  auto& outb = b.add_output(dca::scalar_port("Out"));
  auto& inc = c.add_input(dca::scalar_port("In"));
  auto& ind = d.add_input(dca::scalar_port("In"));
  ep.add_component("/a", a);
  ep.add_component("/b", b);
  ep.add_component("/c", c);
  ep.add_component("/d", d);
  ASSERT_EQ(connect(ep, req("/a", "Out", "/c", "In", "s"), {}), "");
  ASSERT_EQ(connect(ep, req("/a", "Out", "/d", "In", "s"), {}), "");  // fan-out
  ASSERT_EQ(connect(ep, req("/b", "Out", "/c", "In", "s"), {}), "");  // fan-in
  ep.activate("s");
  outa.write(1.0);
  outb.write(2.0);
  EXPECT_EQ(drain(inc), (std::vector<double>{1, 2}));
  EXPECT_EQ(drain(ind), (std::vector<double>{1}));
}

TEST_F(EndpointTest, ConnectRefusesUnknownPortsAndMismatchedTypes) {
  dca::Endpoint ep(io, "a");
  dca::PortSet src, dst;
  src.add_output(dca::vector_port("Out", 3));
  dst.add_input(dca::scalar_port("In1"));
  dst.add_input(dca::vector_port("Force", 6));
  ep.add_component("/src", src);
  ep.add_component("compliant", dst);
  EXPECT_EQ(connect(ep, req("/src", "Out", "compliant", "In2", "s"), {}),
            "no input 'In2' on compliant; inputs are: In1, Force");
  EXPECT_EQ(connect(ep, req("/src", "Out", "compliant", "Force", "s"), {}),
            "output 'Out' is vector[3] but input 'Force' is vector[6]");
  EXPECT_EQ(connect(ep, req("/src", "Nope", "compliant", "In1", "s"), {}),
            "no output 'Nope' on /src; outputs are: Out");
  EXPECT_TRUE(ep.links().empty());
}

// Two endpoints in one process stand for two nodes; the host names choose the socket.
class EndpointSocketTest : public EndpointTest, public ::testing::WithParamInterface<bool> {
 protected:
  void SetUp() override {
    tcp_ = GetParam();
    src_ep = std::make_unique<dca::Endpoint>(io, "a", keyed());
    src_ep->listen(temp_socket(tcp_ ? "src-tcp" : "src-uds"), "127.0.0.1:0");
    out = &src.add_output(dca::vector_port("Out", 8));
    in = &dst.add_input(dca::vector_port("In", 8));
    back = &dst.add_output(dca::vector_port("Back", 8));
    ret = &src.add_input(dca::vector_port("Ret", 8));
    src_ep->add_component("/src", src);
    src_ep->on_event([&](const dca::CommsEvent& e) { src_events.push_back(e); });
    make_dst(keyed());
  }
  // (Re)makes the destination endpoint with `options`, listening, holding /dst.
  void make_dst(dca::EndpointOptions options) {
    dst_ep.reset();
    dst_ep = std::make_unique<dca::Endpoint>(io, tcp_ ? "b" : "a", std::move(options));
    dst_ep->listen(temp_socket(tcp_ ? "tcp" : "uds"), "127.0.0.1:0");
    dst_ep->add_component("/dst", dst);
    dst_ep->on_event([&](const dca::CommsEvent& e) { dst_events.push_back(e); });
  }
  dca::Transport expected() const { return tcp_ ? dca::Transport::Tcp : dca::Transport::Unix; }
  // The destination's data address for this transport.
  std::string dst_address() const {
    const auto loc = dst_ep->location();
    return tcp_ ? loc.data_tcp : "unix:" + loc.data_uds;
  }
  // A valid hello for /src.Out -> /dst.In.
  static std::string hello(const std::string& set = "s") {
    return df::encode_hello({req("/src", "Out", "/dst", "In", set), dca::vector_port("Out", 8)});
  }
  std::string sample_bytes(double v) const {
    const Eigen::VectorXd x = sample(v);
    return std::string(reinterpret_cast<const char*>(x.data()), sizeof(double) * 8);
  }
  // A legitimate connection still delivers exactly what it sends (and nothing else arrived before).
  void expect_only_legit_samples_arrive() {
    EXPECT_EQ(in->stats().samples, 0u);
    EXPECT_EQ(in->queued(), 0u);
    ASSERT_EQ(connect(*src_ep, req("/src", "Out", "/dst", "In", "s"), dst_ep->location()), "");
    src_ep->activate("s");
    out->write(sample(7));
    ASSERT_TRUE(run_until(io, [&] { return in->queued() == 1; }));
    ASSERT_TRUE(in->pop());
    EXPECT_EQ(in->vector(), sample(7));
    EXPECT_EQ(in->stats().samples, 1u);
  }
  Eigen::VectorXd sample(double v) const { return Eigen::VectorXd::Constant(8, v); }
  // Links /src.Out -> /dst.In and back /dst.Back -> /src.Ret in set `set`, active.
  void link_both_ways(const std::string& set = "s") {
    ASSERT_EQ(connect(*src_ep, req("/src", "Out", "/dst", "In", set), dst_ep->location()), "");
    ASSERT_EQ(connect(*dst_ep, req("/dst", "Back", "/src", "Ret", set), src_ep->location()), "");
    src_ep->activate(set);
    dst_ep->activate(set);
  }
  // A sample there and one back arrive.
  void expect_round_trip(double v, dca::Input& there, dca::Output& reply, dca::Input& home) {
    out->write(sample(v));
    ASSERT_TRUE(run_until(io, [&] { return there.queued() == 1; }));
    there.pop();
    EXPECT_EQ(there.vector(), sample(v));
    reply.write(sample(-v));
    ASSERT_TRUE(run_until(io, [&] { return home.queued() == 1; }));
    home.pop();
    EXPECT_EQ(home.vector(), sample(-v));
  }
  bool tcp_ = false;
  std::unique_ptr<dca::Endpoint> src_ep, dst_ep;
  dca::PortSet src, dst;
  dca::Output* out = nullptr;
  dca::Input* in = nullptr;
  dca::Output* back = nullptr;  // /dst.Back
  dca::Input* ret = nullptr;    // /src.Ret
  std::vector<dca::CommsEvent> src_events, dst_events;
};

TEST_P(EndpointSocketTest, PushSamplesFlowOnlyWhileActiveAndSwitchingNeverReconnects) {
  ASSERT_EQ(connect(*src_ep, req("/src", "Out", "/dst", "In", "s"), dst_ep->location()), "");
  ASSERT_EQ(src_ep->links().size(), 1u);
  EXPECT_EQ(src_ep->links()[0].transport, expected());
  EXPECT_EQ(dst_ep->accepted(), 1u);
  out->write(sample(1));  // inactive
  EXPECT_EQ(src_ep->links()[0].skipped, 1u);
  src_ep->activate("s");
  out->write(sample(2));
  out->write(sample(3));
  ASSERT_TRUE(run_until(io, [&] { return in->queued() == 2; }));
  ASSERT_TRUE(in->pop());
  EXPECT_EQ(in->vector(), sample(2));
  src_ep->deactivate("s");
  out->write(sample(4));
  src_ep->activate("s");
  out->write(sample(5));
  ASSERT_TRUE(run_until(io, [&] { return in->queued() == 2; }));
  in->pop();
  EXPECT_EQ(in->vector(), sample(3));
  in->pop();
  EXPECT_EQ(in->vector(), sample(5));
  EXPECT_EQ(src_ep->links()[0].skipped, 2u);
  EXPECT_EQ(dst_ep->accepted(), 1u);  // one socket throughout
  EXPECT_TRUE(src_events.empty());
  EXPECT_TRUE(dst_events.empty());
}

// Lock-step, the clock's owner (Endpoint::set_hold): samples to a held destination are counted as sent but kept
// back, while a link to another destination on the same socket goes on; released, they arrive in order, and a
// sample sent at once after some were kept back goes after them.
TEST_P(EndpointSocketTest, HeldSamplesAreCountedAndSentInOrderWhenReleased) {
  dca::PortSet other;
  dca::Input& other_in = other.add_input(dca::vector_port("In", 8));
  dst_ep->add_component("/other", other);
  ASSERT_EQ(connect(*src_ep, req("/src", "Out", "/dst", "In", "s"), dst_ep->location()), "");
  ASSERT_EQ(connect(*src_ep, req("/src", "Out", "/other", "In", "s"), dst_ep->location()), "");
  src_ep->activate("s");
  src_ep->set_hold([](const std::string& to) { return to == "/dst"; });
  out->write(sample(1));
  out->write(sample(2));
  EXPECT_EQ(src_ep->held(), 2u);
  for (const auto& c : src_ep->sent_counts()) EXPECT_EQ(c.sent, 2u) << c.key;  // counted as sent either way
  ASSERT_TRUE(run_until(io, [&] { return other_in.queued() == 2; }));  // the same socket, after them
  EXPECT_EQ(in->queued(), 0u);
  src_ep->release_held({"/other"});  // nothing kept back for it
  EXPECT_EQ(src_ep->held(), 2u);
  src_ep->release_held({"/dst"});
  EXPECT_EQ(src_ep->held(), 0u);
  ASSERT_TRUE(run_until(io, [&] { return in->queued() == 2; }));
  out->write(sample(3));  // kept back, then the hold ends: 4 goes at once, after 3
  src_ep->set_hold(nullptr);
  out->write(sample(4));
  EXPECT_EQ(src_ep->held(), 0u);
  ASSERT_TRUE(run_until(io, [&] { return in->queued() == 4; }));
  for (double v : {1.0, 2.0, 3.0, 4.0}) {
    ASSERT_TRUE(in->pop());
    EXPECT_EQ(in->vector(), sample(v));
  }
  EXPECT_EQ(src_ep->links()[0].tx_dropped, 0u);
}

// A message port's samples (its type's CDR, docs/data-plane.md "Typed messages") cross the socket as they are,
// and its type with them: another message type is refused at connect.
TEST_P(EndpointSocketTest, MessageSamplesCrossTheSocketAndOnlyToTheirType) {
  auto& cmd = src.add_output(dca::message_port("Cmd", "geometry_msgs/msg/Twist"));
  auto& vel = dst.add_input(dca::message_port("CmdVel", "geometry_msgs/msg/Twist"));
  dst.add_input(dca::message_port("Push", "geometry_msgs/msg/Wrench"));
  EXPECT_EQ(connect(*src_ep, req("/src", "Cmd", "/dst", "Push", "m"), dst_ep->location()),
            "output 'Cmd' is geometry_msgs/msg/Twist but input 'Push' is geometry_msgs/msg/Wrench");
  ASSERT_EQ(connect(*src_ep, req("/src", "Cmd", "/dst", "CmdVel", "m"), dst_ep->location()), "");
  src_ep->activate("m");
  const dca::msgs::Twist t{{0.25, 0, 0}, {0, 0, -1}};
  std::array<std::byte, dca::msgs::cdr_max_size<dca::msgs::Twist>> buf{};
  ASSERT_TRUE(cmd.write_bytes({buf.data(), dca::msgs::cdr_encode(t, buf)}));
  ASSERT_TRUE(run_until(io, [&] { return vel.queued() == 1; }));
  dca::Bytes got;
  ASSERT_EQ(dca::port_detail::read_bytes(vel, got), dca::Read::New);
  dca::msgs::Twist arrived;
  ASSERT_TRUE(dca::msgs::cdr_decode(got, arrived));
  EXPECT_EQ(arrived, t);
}

TEST_P(EndpointSocketTest, PullAnswersWithTheLatestSample) {
  ASSERT_EQ(connect(*src_ep, req("/src", "Out", "/dst", "In", "p", dca::Mode::Pull), dst_ep->location()), "");
  src_ep->activate("p");
  out->write(sample(1));
  out->write(sample(2));
  in->request();
  ASSERT_TRUE(run_until(io, [&] { return in->has_current(); }));
  EXPECT_EQ(in->vector(), sample(2));
  EXPECT_EQ(in->queued(), 0u);
  EXPECT_EQ(in->stats().samples, 1u);  // only the answer travelled
}

TEST_P(EndpointSocketTest, PushOverflowIsCountedAtTheDestination) {
  ASSERT_EQ(connect(*src_ep, req("/src", "Out", "/dst", "In", "s", dca::Mode::Push, 2), dst_ep->location()), "");
  src_ep->activate("s");
  for (int i = 1; i <= 5; ++i) out->write(sample(i));
  ASSERT_TRUE(run_until(io, [&] { return in->stats().samples == 5; }));
  EXPECT_EQ(in->stats().dropped, 3u);
  ASSERT_EQ(dst_events.size(), 1u);
  EXPECT_EQ(dst_events[0].kind, dca::CommsEvent::Kind::Overflow);
}

// A sample too big for one data frame would make the destination fail the whole connection (every link between
// the two processes): the sender drops it, counts it and reports it once; the links on the connection go on.
TEST_P(EndpointSocketTest, ASampleTooBigForAFrameIsDroppedAtTheSender) {
  auto* big = &src.add_output(dca::vectorx_port("Big"));
  auto* big_in = &dst.add_input(dca::vectorx_port("BigIn"));
  ASSERT_EQ(connect(*src_ep, req("/src", "Big", "/dst", "BigIn", "s"), dst_ep->location()), "");
  ASSERT_EQ(connect(*src_ep, req("/src", "Out", "/dst", "In", "s"), dst_ep->location()), "");
  src_ep->activate("s");
  big->write(Eigen::VectorXd::Zero(static_cast<Eigen::Index>(df::kMaxBody / sizeof(double) + 1)));
  big->write(Eigen::VectorXd::Constant(3, 2.0));
  out->write(sample(1));
  ASSERT_TRUE(run_until(io, [&] { return big_in->queued() == 1 && in->queued() == 1; }));
  ASSERT_TRUE(big_in->pop());
  EXPECT_EQ(big_in->vector(), Eigen::VectorXd::Constant(3, 2.0));
  const auto links = src_ep->links();
  ASSERT_EQ(links.size(), 2u);
  const auto& l = links[0].request.out == "Big" ? links[0] : links[1];
  EXPECT_EQ(l.tx_dropped, 1u);
  EXPECT_EQ(l.sent, 1u);
  EXPECT_FALSE(l.broken);
  ASSERT_EQ(src_events.size(), 1u);
  EXPECT_EQ(src_events[0].kind, dca::CommsEvent::Kind::Overflow);
  EXPECT_EQ(src_events[0].port, "Big");
  EXPECT_NE(src_events[0].reason.find("exceeds the data frame limit"), std::string::npos) << src_events[0].reason;
  EXPECT_TRUE(dst_events.empty());
}

TEST_P(EndpointSocketTest, RefusalNamesTheValidPorts) {
  EXPECT_EQ(connect(*src_ep, req("/src", "Out", "/dst", "Inn", "s"), dst_ep->location()),
            "no input 'Inn' on /dst; inputs are: In");
  EXPECT_EQ(connect(*src_ep, req("/src", "Out", "/nobody", "In", "s"), dst_ep->location()),
            std::string("no component '/nobody' at ") + (tcp_ ? "b" : "a"));
  EXPECT_TRUE(src_ep->links().empty());
}

TEST_P(EndpointSocketTest, BrokenConnectionIsReportedAsAnEvent) {
  ASSERT_EQ(connect(*src_ep, req("/src", "Out", "/dst", "In", "s"), dst_ep->location()), "");
  src_ep->activate("s");
  dst_ep.reset();  // the destination process goes away
  ASSERT_TRUE(run_until(io, [&] { return !src_events.empty(); }));
  EXPECT_EQ(src_events[0].kind, dca::CommsEvent::Kind::Broken);
  EXPECT_EQ(src_events[0].component, "/src");
  EXPECT_EQ(src_events[0].peer, "/dst.In");
  EXPECT_EQ(src_events[0].set, "s");
  EXPECT_TRUE(src_ep->links()[0].broken);
  out->write(sample(1));  // never blocks, never throws
}

TEST_P(EndpointSocketTest, SourceGoingAwayIsReportedAtTheDestination) {
  ASSERT_EQ(connect(*src_ep, req("/src", "Out", "/dst", "In", "s"), dst_ep->location()), "");
  src_ep.reset();
  ASSERT_TRUE(run_until(io, [&] { return !dst_events.empty(); }));
  EXPECT_EQ(dst_events[0].kind, dca::CommsEvent::Kind::Broken);
  EXPECT_EQ(dst_events[0].component, "/dst");
  EXPECT_EQ(dst_events[0].peer, "/src.Out");
}

// A restarted destination (dca.supervisor's restart of a leaf): the same connection asked again with the new
// process's address replaces the link to the old one (even before its break is seen); asked again with the
// same address it is the one already made.
TEST_P(EndpointSocketTest, ConnectingAgainToADestinationStartedAnewReplacesTheLink) {
  ASSERT_EQ(connect(*src_ep, req("/src", "Out", "/dst", "In", "s"), dst_ep->location()), "");
  src_ep->activate("s");
  dca::Endpoint fresh(io, tcp_ ? "b" : "a", keyed());
  fresh.listen(temp_socket(tcp_ ? "tcp2" : "uds2"), "127.0.0.1:0");
  dca::PortSet dst2;
  dca::Input& in2 = dst2.add_input(dca::vector_port("In", 8));
  fresh.add_component("/dst", dst2);
  ASSERT_EQ(connect(*src_ep, req("/src", "Out", "/dst", "In", "s"), fresh.location()), "");
  ASSERT_EQ(connect(*src_ep, req("/src", "Out", "/dst", "In", "s"), fresh.location()), "");
  ASSERT_EQ(src_ep->links().size(), 1u);
  EXPECT_TRUE(src_ep->links()[0].active) << "made in an active set: active at once";
  out->write(sample(7));
  ASSERT_TRUE(run_until(io, [&] { return in2.queued() == 1; }));
  EXPECT_EQ(fresh.accepted(), 1u);
  EXPECT_EQ(in->queued(), 0u) << "nothing more for the old destination";
  dst_ep->remove_component("/dst");
  fresh.remove_component("/dst");
}

// A leaf removed and added again in a shared node lives at the same address: the new instance (its registration's
// `instance`, Location::instance) tells it from the old one, so the connection asked again is made anew even
// though the old instance's `Gone` has not arrived yet; asked again for the same instance it is the one made.
TEST_P(EndpointSocketTest, ConnectingAgainToANewInstanceAtTheSameAddressReplacesTheLink) {
  auto loc = dst_ep->location();
  loc.instance = 1;
  ASSERT_EQ(connect(*src_ep, req("/src", "Out", "/dst", "In", "s"), loc), "");
  src_ep->activate("s");
  ASSERT_EQ(connect(*src_ep, req("/src", "Out", "/dst", "In", "s"), loc), "");
  const auto first = src_ep->links()[0].sent;
  out->write(sample(1));
  ASSERT_TRUE(run_until(io, [&] { return in->queued() == 1; }));
  in->pop();
  loc.instance = 2;
  ASSERT_EQ(connect(*src_ep, req("/src", "Out", "/dst", "In", "s"), loc), "");
  ASSERT_EQ(src_ep->links().size(), 1u);
  EXPECT_EQ(src_ep->links()[0].sent, first) << "a new link: its count starts again";
  out->write(sample(2));
  ASSERT_TRUE(run_until(io, [&] { return in->queued() == 1; }));
  ASSERT_TRUE(in->pop());
  EXPECT_EQ(in->vector(), sample(2));
}

// Regression: a data port took a hello from anyone (one injected sample changed a system's result).
TEST_P(EndpointSocketTest, UnauthenticatedHelloIsRefusedAndDeliversNothing) {
  dca::test::RawDataClient c(io, dst_address());
  ASSERT_TRUE(c.connected());
  c.send_frame(df::Kind::Hello, hello());
  c.send_frame(df::Kind::Sample, sample_bytes(99999));
  const auto reply = c.read_frame();
  ASSERT_TRUE(reply);
  EXPECT_EQ(reply->kind, df::Kind::HelloError);
  EXPECT_NE(reply->body.find("authentication required"), std::string::npos) << reply->body;
  EXPECT_TRUE(c.wait_closed());
  EXPECT_EQ(dst_ep->refused(), 1u);
  EXPECT_EQ(dst_ep->accepted(), 0u);
  expect_only_legit_samples_arrive();
}

TEST_P(EndpointSocketTest, WrongKeyIsRefusedAtBothEnds) {
  dca::Endpoint intruder(io, "a", keyed(kOtherKey));
  dca::PortSet p;
  p.add_output(dca::vector_port("Out", 8));
  intruder.add_component("/src", p);
  const auto err = connect(intruder, req("/src", "Out", "/dst", "In", "s"), dst_ep->location());
  EXPECT_NE(err.find("not authenticated"), std::string::npos) << err;
  EXPECT_NE(err.find("key check"), std::string::npos) << err;
  EXPECT_TRUE(intruder.links().empty());
  ASSERT_TRUE(run_until(io, [&] { return dst_ep->refused() == 1; }));
  expect_only_legit_samples_arrive();
}

// A handshake made for a control port (MACs keyed with the cluster key itself, host/net/auth.h) proves nothing on a
// data port: the data port's MACs are keyed with data_key(cluster key).
TEST_P(EndpointSocketTest, ControlPlaneProofIsRefusedOnADataPort) {
  dca::test::RawDataClient c(io, dst_address());
  const std::string nc(dca::auth::kNonceSize, 'c');
  c.send_auth({"hello", 0, dca::wire::Value::map().set("version", dca::wire::kProtocolVersion).set("nonce", nc)});
  dca::wire::Message challenge;
  ASSERT_EQ(c.read_auth(challenge), "");
  const std::string ns = challenge.payload["nonce"].as_string();
  EXPECT_NE(challenge.payload["mac"].as_string(), dca::auth::hmac_sha256(kKey, "dca-auth-1 server" + nc + ns));
  const auto control_proof = dca::auth::hmac_sha256(kKey, "dca-auth-1 client" + nc + ns);
  c.send_auth({"proof", 0, dca::wire::Value::map().set("mac", control_proof)});
  dca::wire::Message answer;
  const auto why = c.read_auth(answer);
  EXPECT_NE(why.find("refused: wrong cluster key"), std::string::npos) << why;
  EXPECT_TRUE(c.wait_closed());
  EXPECT_EQ(dst_ep->refused(), 1u);
  expect_only_legit_samples_arrive();
}

TEST_P(EndpointSocketTest, ReplayedHandshakeIsRefused) {
  std::vector<dca::wire::Message> recorded;
  {
    dca::test::RawDataClient first(io, dst_address());
    ASSERT_EQ(first.handshake(dca::data_key(kKey), &recorded), "");  // a legitimate one, recorded
  }
  ASSERT_EQ(recorded.size(), 2u);  // hello, proof
  dca::test::RawDataClient again(io, dst_address());
  dca::wire::Message challenge;
  again.send_auth(recorded[0]);
  ASSERT_EQ(again.read_auth(challenge), "");  // a fresh nonce: the recorded proof no longer fits
  again.send_auth(recorded[1]);
  dca::wire::Message answer;
  const auto why = again.read_auth(answer);
  EXPECT_NE(why.find("refused: wrong cluster key"), std::string::npos) << why;
  EXPECT_NE(why.find("replayed"), std::string::npos) << why;
  EXPECT_TRUE(again.wait_closed());
  ASSERT_TRUE(run_until(io, [&] { return dst_ep->refused() == 2; }));  // the first left without a hello
  expect_only_legit_samples_arrive();
}

TEST_P(EndpointSocketTest, EndpointsWithoutAKeyRefuseBothWays) {
  dca::Endpoint keyless(io, "a");
  dca::PortSet p;
  p.add_output(dca::vector_port("Out", 8));
  keyless.add_component("/src", p);
  EXPECT_EQ(connect(keyless, req("/src", "Out", "/dst", "In", "s"), dst_ep->location()),
            "cannot connect to /dst.In: this endpoint has no cluster key");
  make_dst({});
  const auto err = connect(*src_ep, req("/src", "Out", "/dst", "In", "s"), dst_ep->location());
  EXPECT_NE(err.find("the peer has no cluster key"), std::string::npos) << err;
  EXPECT_EQ(in->stats().samples, 0u);
}

// Regression: a hello with queue = 4294967295 killed the node (bad_alloc). Over an authenticated connection a
// hostile hello is refused with the field named; the connection and the endpoint live on.
TEST_P(EndpointSocketTest, HostileHelloIsRefusedWithItsFieldAndTheEndpointLives) {
  dca::test::RawDataClient c(io, dst_address());
  ASSERT_EQ(c.handshake(dca::data_key(kKey)), "");
  c.introduce();
  std::string body;
  dca::wire::encode_value(dca::wire::Value::map().set("from", "/src").set("out", "Out").set("to", "/dst")
                              .set("in", "In").set("set", "s").set("type", "vector").set("size", std::int64_t{8})
                              .set("queue", std::int64_t{4294967295}), body);
  c.send_frame(df::Kind::Hello, body, 3);
  const auto refused = c.read_frame();
  ASSERT_TRUE(refused);
  EXPECT_EQ(refused->kind, df::Kind::HelloError);
  EXPECT_EQ(refused->link, 3u);
  EXPECT_EQ(refused->body, "hello: 'queue' is 4294967295 (at most 4096)");
  c.send_frame(df::Kind::Hello, hello(), 4);  // the same connection goes on
  const auto ok = c.read_frame();
  ASSERT_TRUE(ok);
  EXPECT_EQ(ok->kind, df::Kind::HelloOk);
  EXPECT_EQ(in->capacity(), 16u);
  expect_only_legit_samples_arrive();
}

// An authenticated connection introduces its opener before anything else; a hello in its place is refused.
TEST_P(EndpointSocketTest, AHelloBeforeTheIntroductionIsRefused) {
  dca::test::RawDataClient c(io, dst_address());
  ASSERT_EQ(c.handshake(dca::data_key(kKey)), "");
  c.send_frame(df::Kind::Hello, hello());
  const auto reply = c.read_frame();
  ASSERT_TRUE(reply);
  EXPECT_EQ(reply->kind, df::Kind::HelloError);
  EXPECT_EQ(reply->link, 0u);
  EXPECT_EQ(reply->body, "the first data frame after the handshake must introduce the peer");
  EXPECT_TRUE(c.wait_closed());
  EXPECT_EQ(dst_ep->refused(), 1u);
  EXPECT_EQ(dst_ep->accepted(), 0u);
  expect_only_legit_samples_arrive();
}

// Regression: a length prefix of 16 MiB made a data port allocate it before anything was authenticated.
TEST_P(EndpointSocketTest, OversizeLengthPrefixBeforeAuthenticationIsRefusedAtOnce) {
  dca::test::RawDataClient c(io, dst_address());
  c.send_raw(std::string("\x01\x00\x00\x00", 4));  // 16 MiB announced; not one byte of it sent
  const auto reply = c.read_frame();
  ASSERT_TRUE(reply);
  EXPECT_EQ(reply->kind, df::Kind::HelloError);
  EXPECT_NE(reply->body.find("exceeds the limit of 512"), std::string::npos) << reply->body;
  EXPECT_TRUE(c.wait_closed());
  EXPECT_EQ(dst_ep->bytes_received(), 4u);
}

// Regression: a data connection that said nothing stayed open forever.
TEST_P(EndpointSocketTest, SilentConnectionIsClosedAtTheHandshakeDeadline) {
  auto o = keyed();
  o.handshake_timeout = 100ms;
  make_dst(o);
  dca::test::RawDataClient c(io, dst_address());
  c.send_raw(std::string("\x00\x00", 2));  // half a length prefix, then nothing
  EXPECT_TRUE(c.wait_closed());
  EXPECT_EQ(dst_ep->refused(), 1u);
  EXPECT_EQ(dst_ep->accepted(), 0u);
}

// Regression: an authenticated connection holding half a frame stayed open forever.
TEST_P(EndpointSocketTest, HalfAFrameIsClosedAtItsDeadline) {
  auto o = keyed();
  o.partial_frame_timeout = 100ms;
  make_dst(o);
  dca::test::RawDataClient c(io, dst_address());
  ASSERT_EQ(c.handshake(dca::data_key(kKey)), "");
  c.introduce();
  c.send_frame(df::Kind::Hello, hello());
  const auto ok = c.read_frame();
  ASSERT_TRUE(ok);
  EXPECT_EQ(ok->kind, df::Kind::HelloOk);
  c.send_raw(c.frame(df::Kind::Sample, sample_bytes(1)) + c.frame(df::Kind::Sample, sample_bytes(2)).substr(0, 20));
  EXPECT_TRUE(c.wait_closed());
  EXPECT_EQ(in->stats().samples, 1u);  // the whole frame arrived; the half one never did
  ASSERT_EQ(dst_events.size(), 1u);
  EXPECT_EQ(dst_events[0].kind, dca::CommsEvent::Kind::Broken);
  EXPECT_NE(dst_events[0].reason.find("a partial data frame was held for more than 100 ms"), std::string::npos)
      << dst_events[0].reason;
}

// One socket connection between two endpoints carries their links both ways (a reply rides the connection its
// request came on, so TCP piggybacks its acknowledgement).
TEST_P(EndpointSocketTest, BothDirectionsRideOneConnection) {
  link_both_ways();
  EXPECT_EQ(src_ep->connections(), 1u);
  EXPECT_EQ(dst_ep->connections(), 1u);
  EXPECT_EQ(dst_ep->accepted(), 1u);
  EXPECT_EQ(src_ep->accepted(), 0u) << "the link back opened no connection of its own";
  expect_round_trip(3, *in, *back, *ret);
  expect_round_trip(4, *in, *back, *ret);
  EXPECT_EQ(dst_ep->links()[0].transport, expected());
  EXPECT_TRUE(src_events.empty());
  EXPECT_TRUE(dst_events.empty());
}

// Links made or removed while the connection is up ride it; a refused hello refuses that link only.
TEST_P(EndpointSocketTest, LinksComeAndGoOnAnOpenConnection) {
  link_both_ways();
  dca::Input& in2 = dst.add_input(dca::vector_port("In2", 8));
  EXPECT_EQ(connect(*src_ep, req("/src", "Out", "/dst", "Nope", "t"), dst_ep->location()),
            "no input 'Nope' on /dst; inputs are: In, In2");
  ASSERT_EQ(connect(*src_ep, req("/src", "Out", "/dst", "In2", "t"), dst_ep->location()), "");
  ASSERT_EQ(connect(*dst_ep, req("/dst", "Back", "/src", "Ret", "t"), src_ep->location()), "");
  src_ep->activate("t");
  out->write(sample(5));
  ASSERT_TRUE(run_until(io, [&] { return in->queued() == 1 && in2.queued() == 1; }));
  EXPECT_EQ(src_ep->connections(), 1u);
  EXPECT_EQ(dst_ep->connections(), 1u);
  src_ep->disconnect_set("s");  // the destination is told; the connection and set t stay
  ASSERT_TRUE(run_until(io, [&] { return !dst_events.empty(); }));
  EXPECT_EQ(dst_events[0].kind, dca::CommsEvent::Kind::Broken);
  EXPECT_EQ(dst_events[0].port, "In");
  EXPECT_EQ(dst_events[0].reason, "closed by peer");
  out->write(sample(6));
  ASSERT_TRUE(run_until(io, [&] { return in2.queued() == 2; }));
  EXPECT_EQ(in->queued(), 1u) << "nothing more on the removed link";
  EXPECT_EQ(dst_ep->connections(), 1u);
  EXPECT_TRUE(src_events.empty());
}

// Two endpoints that open connections to each other at the same instant (a supervisor makes all its links at
// once) end with their links on one connection, the one opened by the endpoint whose address sorts first: a
// link that has sent nothing moves there unseen, and the other connection, idle, closes.
TEST_P(EndpointSocketTest, SimultaneousOpensEndOnOneConnection) {
  std::optional<std::string> there, back_again;
  src_ep->connect(req("/src", "Out", "/dst", "In", "s"), dst_ep->location(), [&](const std::string& e) { there = e; });
  dst_ep->connect(req("/dst", "Back", "/src", "Ret", "s"), src_ep->location(),
                  [&](const std::string& e) { back_again = e; });
  ASSERT_TRUE(run_until(io, [&] { return there && back_again; }));
  EXPECT_EQ(*there, "");
  EXPECT_EQ(*back_again, "");
  ASSERT_TRUE(run_until(io, [&] { return src_ep->connections() == 1 && dst_ep->connections() == 1; }));
  EXPECT_EQ(src_ep->accepted() + dst_ep->accepted(), 1u);
  src_ep->activate("s");
  dst_ep->activate("s");
  expect_round_trip(1, *in, *back, *ret);
  EXPECT_EQ(src_ep->connections(), 1u);
  EXPECT_TRUE(src_events.empty());
  EXPECT_TRUE(dst_events.empty());
  EXPECT_EQ(src_ep->refused() + dst_ep->refused(), 0u);
}

// Two endpoints opening to each other at once: a link that moves to the other connection says hello on both
// sockets, whose frames may be read in either order. Read last, its earlier hello neither resets the reader's
// gate nor takes it over, so the samples after the move are taken and counted. (A door run once waited forever
// for a command lost so: `waited 5000 ms for sample 1 ... got 0`.)
TEST_P(EndpointSocketTest, AMovedLinksEarlierHelloReadLastLeavesTheGateToTheLaterOne) {
  dca::test::RawDataClient first(io, dst_address()), second(io, dst_address());
  ASSERT_EQ(first.handshake(dca::data_key(kKey)), "");
  ASSERT_EQ(second.handshake(dca::data_key(kKey)), "");
  first.introduce(src_ep->location());
  second.introduce(src_ep->location());
  const auto r = req("/src", "Out", "/dst", "In", "s");
  auto hello_n = [&](std::uint64_t serial) {
    df::Hello h{r, dca::vector_port("Out", 8)};
    h.sender = 77;
    h.serial = serial;
    return df::encode_hello(h);
  };
  dst_ep->set_gated(true);
  second.send_frame(df::Kind::Hello, hello_n(1), 3);  // the later hello, read first
  auto ok = second.read_frame();
  ASSERT_TRUE(ok && ok->kind == df::Kind::HelloOk);
  second.send_frame(df::Kind::Sample, sample_bytes(1), 3);
  ASSERT_TRUE(run_until(io, [&] { return dst_ep->received(dca::link_key(r)) == 1; }));
  first.send_frame(df::Kind::Hello, hello_n(0), 1);  // the earlier one, read last
  ok = first.read_frame();
  ASSERT_TRUE(ok && ok->kind == df::Kind::HelloOk);
  first.send_frame(df::Kind::Close, "moved", 1);
  second.send_frame(df::Kind::Sample, sample_bytes(2), 3);
  ASSERT_TRUE(run_until(io, [&] { return dst_ep->received(dca::link_key(r)) == 2; }))
      << "got " << dst_ep->received(dca::link_key(r));
  EXPECT_TRUE(dst_ep->release(dca::link_key(r), 2));
  ASSERT_EQ(in->queued(), 2u);
  in->pop();
  EXPECT_EQ(in->vector(), sample(1));
  in->pop();
  EXPECT_EQ(in->vector(), sample(2));
  EXPECT_TRUE(dst_events.empty()) << "a move is reported nowhere";
}

// A restarted process (a new endpoint at a new address): its links both ways are made again on one new
// connection, and the old connection's links were reported broken.
TEST_P(EndpointSocketTest, RestartedPeerGetsANewConnectionCarryingBothWays) {
  link_both_ways();
  expect_round_trip(1, *in, *back, *ret);
  dst_ep->remove_component("/dst");
  dst_ep.reset();  // the destination process dies
  ASSERT_TRUE(run_until(io, [&] { return src_events.size() == 2; }));
  dca::Endpoint fresh(io, tcp_ ? "b" : "a", keyed());
  fresh.listen(temp_socket(tcp_ ? "tcp2" : "uds2"), "127.0.0.1:0");
  dca::PortSet dst2;
  dca::Input& in2 = dst2.add_input(dca::vector_port("In", 8));
  dca::Output& back2 = dst2.add_output(dca::vector_port("Back", 8));
  fresh.add_component("/dst", dst2);
  ASSERT_EQ(connect(*src_ep, req("/src", "Out", "/dst", "In", "s"), fresh.location()), "");
  ASSERT_EQ(connect(fresh, req("/dst", "Back", "/src", "Ret", "s"), src_ep->location()), "");
  fresh.activate("s");
  ASSERT_EQ(src_ep->links().size(), 1u) << "the link to the old process was replaced";
  EXPECT_FALSE(src_ep->links()[0].broken);
  expect_round_trip(2, in2, back2, *ret);
  EXPECT_EQ(src_ep->connections(), 1u);
  EXPECT_EQ(fresh.connections(), 1u);
  EXPECT_EQ(fresh.accepted(), 1u);
  fresh.remove_component("/dst");
}

// A peer may open a second connection (two endpoints connecting to each other at the same instant do): it is
// authenticated like the first, its links work, and its end ends only its own links.
TEST_P(EndpointSocketTest, ASecondConnectionFromAPeerWorksBesideTheFirst) {
  link_both_ways();
  {
    dca::test::RawDataClient c(io, dst_address());
    ASSERT_EQ(c.handshake(dca::data_key(kKey)), "");
    c.introduce(src_ep->location());  // it says it is the same endpoint
    // (a link of its own: the same link again would take the reader's gate over, as a restarted writer's does)
    c.send_frame(df::Kind::Hello, hello("s2"), 7);
    const auto ok = c.read_frame();
    ASSERT_TRUE(ok);
    EXPECT_EQ(ok->kind, df::Kind::HelloOk);
    EXPECT_EQ(ok->link, 7u);
    EXPECT_EQ(dst_ep->accepted(), 2u);
    c.send_frame(df::Kind::Sample, sample_bytes(8), 7);
    ASSERT_TRUE(run_until(io, [&] { return in->queued() == 1; }));
    in->pop();
    EXPECT_EQ(in->vector(), sample(8));
  }  // the second connection closes
  ASSERT_TRUE(run_until(io, [&] { return dst_events.size() == 1; }));
  EXPECT_EQ(dst_events[0].kind, dca::CommsEvent::Kind::Broken);
  EXPECT_EQ(dst_ep->accepted(), 1u);
  expect_round_trip(9, *in, *back, *ret);  // the first connection's links both ways are untouched
  EXPECT_TRUE(src_events.empty());
}

// A link back towards an opener never rides an unauthenticated connection: an unauthenticated client claiming
// to be an endpoint is refused, and the link back opens (and authenticates) a connection of its own.
TEST_P(EndpointSocketTest, ALinkBackNeedsAnAuthenticatedConnection) {
  dca::test::RawDataClient c(io, dst_address());
  c.introduce(src_ep->location());
  const auto reply = c.read_frame();
  ASSERT_TRUE(reply);
  EXPECT_EQ(reply->kind, df::Kind::HelloError);
  EXPECT_NE(reply->body.find("authentication required"), std::string::npos) << reply->body;
  EXPECT_TRUE(c.wait_closed());
  ASSERT_EQ(connect(*dst_ep, req("/dst", "Back", "/src", "Ret", "s"), src_ep->location()), "");
  dst_ep->activate("s");
  EXPECT_EQ(src_ep->accepted(), 1u);
  back->write(sample(4));
  ASSERT_TRUE(run_until(io, [&] { return ret->queued() == 1; }));
  EXPECT_EQ(dst_ep->refused(), 1u);
  // A wrong key on the way back is refused as on the way there.
  dca::Endpoint intruder(io, tcp_ ? "b" : "a", keyed(kOtherKey));
  dca::PortSet p;
  p.add_output(dca::vector_port("Back", 8));
  intruder.add_component("/dst2", p);
  const auto err = connect(intruder, req("/dst2", "Back", "/src", "Ret", "s"), src_ep->location());
  EXPECT_NE(err.find("not authenticated"), std::string::npos) << err;
  EXPECT_EQ(ret->stats().samples, 1u);
}

// When the one connection drops, every link on it is reported broken at both ends, whichever way it went.
TEST_P(EndpointSocketTest, ADroppedConnectionBreaksTheLinksBothWays) {
  link_both_ways();
  expect_round_trip(1, *in, *back, *ret);
  dst_ep.reset();  // the destination process goes away
  ASSERT_TRUE(run_until(io, [&] { return src_events.size() == 2; }));
  std::vector<std::string> ports;
  for (const auto& e : src_events) {
    EXPECT_EQ(e.kind, dca::CommsEvent::Kind::Broken);
    EXPECT_EQ(e.component, "/src");
    ports.push_back(e.port + " <-> " + e.peer);
  }
  std::sort(ports.begin(), ports.end());
  EXPECT_EQ(ports, (std::vector<std::string>{"Out <-> /dst.In", "Ret <-> /dst.Back"}));
  EXPECT_EQ(src_ep->connections(), 0u);
  EXPECT_TRUE(src_ep->links()[0].broken);
}

// The same from the other side: the opener goes away; the acceptor reports both its links.
TEST_P(EndpointSocketTest, ADroppedConnectionIsReportedAtTheAcceptorBothWays) {
  link_both_ways();
  expect_round_trip(1, *in, *back, *ret);
  src_ep.reset();
  ASSERT_TRUE(run_until(io, [&] { return dst_events.size() == 2; }));
  std::vector<std::string> ports;
  for (const auto& e : dst_events) ports.push_back(e.port + " <-> " + e.peer);
  std::sort(ports.begin(), ports.end());
  EXPECT_EQ(ports, (std::vector<std::string>{"Back <-> /src.Ret", "In <-> /src.Out"}));
  EXPECT_EQ(dst_ep->connections(), 0u);
}

INSTANTIATE_TEST_SUITE_P(Transports, EndpointSocketTest, ::testing::Values(false, true),
                         [](const auto& p) { return p.param ? "Tcp" : "Unix"; });

TEST_F(EndpointTest, ConnectingToNothingFailsWithAReason) {
  dca::Endpoint ep(io, "a", keyed());
  dca::PortSet src;
  src.add_output(dca::scalar_port("Out"));
  ep.add_component("/src", src);
  const auto err = connect(ep, req("/src", "Out", "/dst", "In", "s"), {"b", "", "127.0.0.1:1"});
  EXPECT_NE(err.find("cannot connect to /dst.In at 127.0.0.1:1"), std::string::npos) << err;
  EXPECT_TRUE(ep.links().empty());
}

}  // namespace
