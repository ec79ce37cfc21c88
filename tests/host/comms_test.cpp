// Data plane: ports, in-process / Unix-socket / TCP connections, push and pull, sets, overflow, broken links.
#include "host/comms.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <functional>
#include <optional>

#include <boost/asio/io_context.hpp>

#include "host/comms_internal.h"

namespace {

using namespace std::chrono_literals;

// Runs the io_context until `pred` holds or `timeout` passes (event-driven: no sleeping).
bool run_until(boost::asio::io_context& io, const std::function<bool()>& pred, std::chrono::milliseconds timeout = 5s) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (!pred()) {
    if (std::chrono::steady_clock::now() >= deadline) return false;
    io.restart();
    io.run_one_for(10ms);
  }
  return true;
}

std::string temp_socket(const std::string& tag) {
  return (std::filesystem::temp_directory_path() / ("dca-comms-" + std::to_string(::getpid()) + "-" + tag + ".sock")).string();
}

std::vector<double> drain(dca::Input& in) {
  std::vector<double> v;
  while (in.pop()) v.push_back(in.scalar());
  return v;
}

class CommsTest : public ::testing::Test {
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

TEST_F(CommsTest, NamesTypesAndModes) {
  EXPECT_EQ(dca::to_string(dca::PortType::VectorX), "vectorx");
  EXPECT_EQ(dca::port_type_from("vector"), dca::PortType::Vector);
  EXPECT_FALSE(dca::port_type_from("matrix"));
  EXPECT_EQ(dca::mode_from("pull"), dca::Mode::Pull);
  EXPECT_FALSE(dca::mode_from("poll"));
}

TEST_F(CommsTest, CompatibilityChecksTypeAndSize) {
  EXPECT_EQ(dca::compatibility_error(dca::vector_port("A", 3), dca::vector_port("B", 3)), "");
  EXPECT_EQ(dca::compatibility_error(dca::vector_port("A", 3), dca::vector_port("B", 4)),
            "output 'A' is vector[3] but input 'B' is vector[4]");
  EXPECT_EQ(dca::compatibility_error(dca::scalar_port("A"), dca::vectorx_port("B")),
            "output 'A' is scalar but input 'B' is vectorx");
}

TEST_F(CommsTest, UnknownPortErrorListsTheValidNames) {
  dca::PortSet ps;
  ps.add_input(dca::scalar_port("In1"));
  ps.add_input(dca::vector_port("Force", 6, "N"));
  EXPECT_EQ(ps.no_such_input("compliant", "In2"), "no input 'In2' on compliant; inputs are: In1, Force");
  EXPECT_EQ(ps.no_such_output("compliant", "Out"), "no output 'Out' on compliant; it has no outputs");
  EXPECT_THROW(ps.add_input(dca::scalar_port("In1")), std::invalid_argument);
}

TEST_F(CommsTest, ChoosesTransportFromWhereTheEndsLive) {
  const dca::Location there{"b", "/tmp/x.sock", "127.0.0.1:9"};
  EXPECT_EQ(dca::choose_transport("a", true, there), dca::Transport::InProcess);
  EXPECT_EQ(dca::choose_transport("b", false, there), dca::Transport::Unix);
  EXPECT_EQ(dca::choose_transport("a", false, there), dca::Transport::Tcp);
}

TEST_F(CommsTest, WrongSizeSampleIsRejectedAndCounted) {
  dca::Output out(dca::vector_port("Out", 3));
  EXPECT_FALSE(out.write(Eigen::VectorXd::Zero(2)));
  EXPECT_FALSE(out.write(1.0));
  EXPECT_TRUE(out.write(Eigen::Vector3d(1, 2, 3)));
  EXPECT_EQ(out.stats().rejected, 2u);
  EXPECT_EQ(out.stats().samples, 1u);
}

TEST_F(CommsTest, InProcessPushDeliversOnlyWhileTheSetIsActive) {
  dca::Endpoint ep(io, "a");
  dca::PortSet src, dst;
  auto& out = src.add_output(dca::scalar_port("Out"));
  auto& in = dst.add_input(dca::scalar_port("In"));
  ep.add_component("/src", src);
  ep.add_component("/dst", dst);
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

TEST_F(CommsTest, PushOverflowDropsTheOldestAndCountsIt) {
  dca::Endpoint ep(io, "a");
  std::vector<dca::CommsEvent> events;
  ep.on_event([&](const dca::CommsEvent& e) { events.push_back(e); });
  dca::PortSet src, dst;
  auto& out = src.add_output(dca::scalar_port("Out"));
  auto& in = dst.add_input(dca::scalar_port("In"), 1);
  ep.add_component("/src", src);
  ep.add_component("/dst", dst);
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

TEST_F(CommsTest, InProcessPullGivesTheLatestSampleOnRequest) {
  dca::Endpoint ep(io, "a");
  dca::PortSet src, dst;
  auto& out = src.add_output(dca::scalar_port("Out"));
  auto& in = dst.add_input(dca::scalar_port("In"));
  ep.add_component("/src", src);
  ep.add_component("/dst", dst);
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

TEST_F(CommsTest, FanOutAndFanIn) {
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

TEST_F(CommsTest, ConnectRefusesUnknownPortsAndMismatchedTypes) {
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
class CommsSocketTest : public CommsTest, public ::testing::WithParamInterface<bool> {
 protected:
  void SetUp() override {
    tcp_ = GetParam();
    src_ep = std::make_unique<dca::Endpoint>(io, "a");
    dst_ep = std::make_unique<dca::Endpoint>(io, tcp_ ? "b" : "a");
    dst_ep->listen(temp_socket(tcp_ ? "tcp" : "uds"), "127.0.0.1:0");
    out = &src.add_output(dca::vector_port("Out", 8));
    in = &dst.add_input(dca::vector_port("In", 8));
    src_ep->add_component("/src", src);
    dst_ep->add_component("/dst", dst);
    src_ep->on_event([&](const dca::CommsEvent& e) { src_events.push_back(e); });
    dst_ep->on_event([&](const dca::CommsEvent& e) { dst_events.push_back(e); });
  }
  dca::Transport expected() const { return tcp_ ? dca::Transport::Tcp : dca::Transport::Unix; }
  Eigen::VectorXd sample(double v) const { return Eigen::VectorXd::Constant(8, v); }
  bool tcp_ = false;
  std::unique_ptr<dca::Endpoint> src_ep, dst_ep;
  dca::PortSet src, dst;
  dca::Output* out = nullptr;
  dca::Input* in = nullptr;
  std::vector<dca::CommsEvent> src_events, dst_events;
};

TEST_P(CommsSocketTest, PushSamplesFlowOnlyWhileActiveAndSwitchingNeverReconnects) {
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

TEST_P(CommsSocketTest, PullAnswersWithTheLatestSample) {
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

TEST_P(CommsSocketTest, PushOverflowIsCountedAtTheDestination) {
  ASSERT_EQ(connect(*src_ep, req("/src", "Out", "/dst", "In", "s", dca::Mode::Push, 2), dst_ep->location()), "");
  src_ep->activate("s");
  for (int i = 1; i <= 5; ++i) out->write(sample(i));
  ASSERT_TRUE(run_until(io, [&] { return in->stats().samples == 5; }));
  EXPECT_EQ(in->stats().dropped, 3u);
  ASSERT_EQ(dst_events.size(), 1u);
  EXPECT_EQ(dst_events[0].kind, dca::CommsEvent::Kind::Overflow);
}

TEST_P(CommsSocketTest, RefusalNamesTheValidPorts) {
  EXPECT_EQ(connect(*src_ep, req("/src", "Out", "/dst", "Inn", "s"), dst_ep->location()),
            "no input 'Inn' on /dst; inputs are: In");
  EXPECT_EQ(connect(*src_ep, req("/src", "Out", "/nobody", "In", "s"), dst_ep->location()),
            std::string("no component '/nobody' at ") + (tcp_ ? "b" : "a"));
  EXPECT_TRUE(src_ep->links().empty());
}

TEST_P(CommsSocketTest, BrokenConnectionIsReportedAsAnEvent) {
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

TEST_P(CommsSocketTest, SourceGoingAwayIsReportedAtTheDestination) {
  ASSERT_EQ(connect(*src_ep, req("/src", "Out", "/dst", "In", "s"), dst_ep->location()), "");
  src_ep.reset();
  ASSERT_TRUE(run_until(io, [&] { return !dst_events.empty(); }));
  EXPECT_EQ(dst_events[0].kind, dca::CommsEvent::Kind::Broken);
  EXPECT_EQ(dst_events[0].component, "/dst");
  EXPECT_EQ(dst_events[0].peer, "/src.Out");
}

INSTANTIATE_TEST_SUITE_P(Transports, CommsSocketTest, ::testing::Values(false, true),
                         [](const auto& p) { return p.param ? "Tcp" : "Unix"; });

TEST_F(CommsTest, ConnectingToNothingFailsWithAReason) {
  dca::Endpoint ep(io, "a");
  dca::PortSet src;
  src.add_output(dca::scalar_port("Out"));
  ep.add_component("/src", src);
  const auto err = connect(ep, req("/src", "Out", "/dst", "In", "s"), {"b", "", "127.0.0.1:1"});
  EXPECT_NE(err.find("cannot connect to /dst.In at 127.0.0.1:1"), std::string::npos) << err;
  EXPECT_TRUE(ep.links().empty());
}

TEST_F(CommsTest, FrameParserRejectsBadFrames) {
  using dca::comms::Parse;
  std::vector<std::byte> buf(dca::comms::kHeader + 3);
  dca::comms::put_header(buf.data(), dca::comms::Kind::Sample, 3);
  dca::comms::Frame f;
  std::size_t used = 0;
  std::string err;
  EXPECT_EQ(dca::comms::parse_frame(buf, f, used, err), Parse::Ok);
  EXPECT_EQ(used, buf.size());
  EXPECT_EQ(f.body.size(), 3u);
  for (std::size_t n = 0; n < buf.size(); ++n)  // every truncation asks for more
    EXPECT_EQ(dca::comms::parse_frame({buf.data(), n}, f, used, err), Parse::NeedMore) << n;
  buf[4] = std::byte{99};
  EXPECT_EQ(dca::comms::parse_frame(buf, f, used, err), Parse::Error);
  EXPECT_EQ(err, "unknown data frame kind 99");
  std::vector<std::byte> big(8);
  dca::comms::put_header(big.data(), dca::comms::Kind::Sample, dca::comms::kMaxFrame);
  EXPECT_EQ(dca::comms::parse_frame(big, f, used, err), Parse::Error);
  std::vector<std::byte> empty(4, std::byte{0});
  EXPECT_EQ(dca::comms::parse_frame(empty, f, used, err), Parse::Error);
}

TEST_F(CommsTest, HelloRoundTripsAndRejectsGarbage) {
  dca::comms::Hello h{req("/a", "Out", "/b", "In", "g:x[l]", dca::Mode::Pull, 7), dca::vector_port("Out", 8)};
  const auto body = dca::comms::encode_hello(h);
  dca::comms::Hello back;
  std::string err;
  ASSERT_TRUE(dca::comms::decode_hello({reinterpret_cast<const std::byte*>(body.data()), body.size()}, back, err)) << err;
  EXPECT_EQ(back.request.to, "/b");
  EXPECT_EQ(back.request.set, "g:x[l]");
  EXPECT_EQ(back.request.mode, dca::Mode::Pull);
  EXPECT_EQ(back.request.queue, 7u);
  EXPECT_EQ(back.out.type, dca::PortType::Vector);
  EXPECT_EQ(back.out.size, 8u);
  const std::string junk = "\x93\x01\x02";
  EXPECT_FALSE(dca::comms::decode_hello({reinterpret_cast<const std::byte*>(junk.data()), junk.size()}, back, err));
  EXPECT_FALSE(err.empty());
}

}  // namespace
