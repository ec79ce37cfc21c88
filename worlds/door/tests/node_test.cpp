// The world as a process (sim/world_node.h), in one test process: a real daemon, the world hosted by the node
// runtime, and a node on simulated time that subscribes to it. Lock-step: the node's timers run exactly once
// per period of simulated time, it sees the world's sensors through a device-style connection, its commands
// move the robot, and two identical runs give identical results.
#include "sim/device_node.h"

#include <gtest/gtest.h>

#include <chrono>
#include <functional>
#include <optional>

#include "host/timers.h"
#include "host/codec/data_frame.h"
#include "host/net/endpoint.h"
#include "tests/support/key_dir.h"
#include "tests/support/raw_data_client.h"
#include "tests/support/sim_world.h"

namespace {

// Drives the base forward at 0.2 m/s every 10 ms and counts its ticks and the arm.q samples it saw.
class Driver final : public dca::Component {
 public:
  Driver(std::string name, dca::TimerServer& t) : name_(std::move(name)), timers(t) {
    q = &ports_.add_input(dca::vector_port("Q", 6), 16);
    cmd = &ports_.add_output(dca::vector_port("Cmd", 3));
  }
  const std::string& name() const override { return name_; }
  dca::PortSet& ports() override { return ports_; }
  bool configure(std::string*) override { return true; }
  bool start(dca::Bytes, std::string*) override {
    timer = timers.every(10'000'000, [this] {
      ++ticks;
      tick_times.push_back(timers.now());
      if (q->take_latest()) ++q_seen;
      Eigen::Vector3d v(0.2, 0, 0);
      cmd->write(v);
    });
    return true;
  }
  void halt() override { timers.cancel(timer); }
  dca::Input* q = nullptr;
  dca::Output* cmd = nullptr;
  int ticks = 0, q_seen = 0;
  std::vector<dca::Nanos> tick_times;

 private:
  std::string name_;
  dca::TimerServer& timers;
  dca::TimerServer::Id timer = 0;
  dca::PortSet ports_;
};

using namespace std::chrono_literals;
using dca::wire::Message;
using dca::wire::Value;

class WorldNodeTest : public ::testing::Test {
 protected:
  void SetUp() override { ASSERT_TRUE(keys.ok()) << keys.error; }

  struct Run {
    double x = 0, y = 0, yaw = 0;
    int ticks = 0, q_seen = 0;
    std::vector<dca::Nanos> tick_times;
    Value status;
  };

  // One run: daemon, world (duration `seconds`), driver node wired both ways, `go`, until the world holds.
  // `midway`: called with time held at half the duration (then it flows on).
  using Midway = std::function<void(dca::test::SimWorld&, const dca::Channel::Ptr& to_world)>;
  Run run_once(double seconds, bool with_stalled_subscriber = false, const Midway& midway = {}) {
    dca::Loop loop;
    dca::DaemonOptions dopts;
    dopts.host = "h";
    dopts.key = keys.key;
    dca::sim::DeviceNodeOptions wo;
    wo.duration = seconds;
    wo.tick_timeout_ms = 300;
    dca::test::SimWorld sim(loop, dopts, wo, keys.key_file);
    std::string error;
    EXPECT_TRUE(sim.start(&error)) << error;

    Driver* drv = nullptr;
    auto dnode = start_driver(sim, &drv);
    if (!drv) return {};
    // The supervisor's side: channels to the world and to the driver, found by name at the daemon.
    auto to_world = open(sim, sim.control_of("world"));
    auto to_drv = open(sim, sim.control_of("/drv"));
    if (!to_world || !to_drv) return {};
    wire(sim, to_world, to_drv);
    dca::Channel::Ptr stalled;
    if (with_stalled_subscriber) {
      stalled = open(sim, sim.control_of("world"));
      stalled->on_message([](const Message&) {});  // takes the advances and never answers
      stalled->request({"clock", 0, Value::map().set("name", "/stalled")}, 5s, [](dca::Response) {});
    }
    if (midway) {
      const auto half = static_cast<std::int64_t>(seconds * 5e8);
      call(sim, to_world, "hold", Value::map().set("at", half));
      call(sim, to_world, "go");
      EXPECT_TRUE(loop.run_until([&] { return sim.world_node.now() >= half; }, 60s));
      EXPECT_EQ(call(sim, to_world, "hold")["now"].as_int(), half);
      midway(sim, to_world);
    }
    call(sim, to_world, "go");
    EXPECT_TRUE(loop.run_until([&] { return sim.held; }, 60s)) << "the world did not reach its duration";
    Run out = result(*drv, call(sim, to_world, "status"));
    dnode->shutdown("test over");
    sim.stop("test over");
    return out;
  }

  // The driver node on simulated time, started; *drv is its component (nullptr if it did not start).
  std::unique_ptr<dca::Node> start_driver(dca::test::SimWorld& sim, Driver** drv) {
    dca::NodeOptions dn;
    dn.type = "Driver";
    dn.name = "/drv";
    dn.daemon = sim.daemon.address().str();
    dn.key_file = keys.key_file;
    dn.clock = dca::ClockKind::Simulated;
    auto node = std::make_unique<dca::Node>(sim.loop, dn,
                                            [drv](const std::string&, const std::string& n, const std::string&,
                                                  const std::vector<std::string>&, dca::TimerServer& t) {
                                              auto c = std::make_unique<Driver>(n, t);
                                              *drv = c.get();
                                              return c;
                                            });
    std::optional<std::string> started;
    node->start([&](const std::string& e) { started = e; });
    EXPECT_TRUE(sim.loop.run_until([&] { return started.has_value(); }, 10s));
    EXPECT_EQ(started.value_or("timeout"), "");
    return node;
  }

  // arm.q from the world to the driver's Q, the driver's Cmd to the world's base.cmd_vel, then run.
  void wire(dca::test::SimWorld& sim, const dca::Channel::Ptr& to_world, const dca::Channel::Ptr& to_drv) {
    call(sim, to_world, "connect",
         Value::map().set("out", "arm.q").set("to", "/drv").set("in", "Q").set("set", "/drv:device"));
    call(sim, to_world, "activate", Value::map().set("set", "/drv:device"));
    call(sim, to_drv, "connect",
         Value::map().set("out", "Cmd").set("to", "world").set("in", "base.cmd_vel").set("set", "/drv:device"));
    call(sim, to_drv, "activate", Value::map().set("set", "/drv:device"));
    call(sim, to_drv, "run");
  }

  static Run result(const Driver& drv, Value status) {
    Run out;
    out.status = std::move(status);
    const auto& p = out.status["base_pose"].as_array();
    if (p.size() == 3) {
      out.x = p[0].as_float();
      out.y = p[1].as_float();
      out.yaw = p[2].as_float();
    }
    out.ticks = drv.ticks;
    out.q_seen = drv.q_seen;
    out.tick_times = drv.tick_times;
    return out;
  }

  static dca::Channel::Ptr open(dca::test::SimWorld& sim, const std::string& addr) {
    std::string error;
    auto ch = sim.open(addr, &error);
    EXPECT_TRUE(ch) << error;
    return ch;
  }

  static Value call(dca::test::SimWorld& sim, const dca::Channel::Ptr& ch, const std::string& type,
                    Value payload = Value::map()) {
    const auto r = sim.call(ch, type, std::move(payload));
    EXPECT_TRUE(r.ok()) << type << ": " << r.error;
    return r.message.payload;
  }

  dca::test::KeyDir keys{"world-node-test"};
};

TEST_F(WorldNodeTest, NodeTicksInLockStepAndItsCommandsMoveTheRobot) {
  const auto r = run_once(1.0);
  // Aligned 10 ms timers from t = 0: ticks at 10, 20, ..., 1000 ms, each exactly once.
  ASSERT_EQ(r.ticks, 100);
  for (int i = 0; i < r.ticks; ++i) EXPECT_EQ(r.tick_times[i], (i + 1) * 10'000'000LL) << i;
  // The world publishes before each tick: every tick saw a fresh arm.q sample.
  EXPECT_EQ(r.q_seen, 100);
  // 0.2 m/s forward for about a second, from the nominal start (x = 0).
  EXPECT_NEAR(r.x, 0.2 * 0.99, 0.03);
  EXPECT_NEAR(r.y, 0.0, 1e-3);
  EXPECT_EQ(r.status["t"].as_float(), 1.0);
  EXPECT_EQ(r.status["subscribers"].as_array().size(), 1u);
}

TEST_F(WorldNodeTest, TwoRunsAreIdentical) {
  const auto a = run_once(0.5);
  const auto b = run_once(0.5);
  EXPECT_EQ(a.ticks, b.ticks);
  EXPECT_EQ(a.x, b.x);
  EXPECT_EQ(a.y, b.y);
  EXPECT_EQ(a.yaw, b.yaw);
}

TEST_F(WorldNodeTest, AStalledSubscriberIsDroppedByName) {
  const auto r = run_once(0.2, true);
  EXPECT_EQ(r.ticks, 20);  // the others go on
  const auto& dropped = r.status["dropped"].as_array();
  ASSERT_EQ(dropped.size(), 1u);
  EXPECT_NE(dropped[0].as_string().find("/stalled: did not answer the advance"), std::string::npos)
      << dropped[0].as_string();
}

// The world's device ports take samples only from the cluster: samples sent by anyone to base.cmd_vel
// must not turn the robot's base. A hello without the handshake, and one after a handshake with another
// key, are refused; base.cmd_vel has received nothing.
TEST_F(WorldNodeTest, DevicePortsRefuseHellosWithoutTheClusterKey) {
  dca::Loop loop;
  dca::DaemonOptions dopts;
  dopts.host = "h";
  dopts.key = keys.key;
  dca::test::SimWorld sim(loop, dopts, {}, keys.key_file);
  std::string error;
  ASSERT_TRUE(sim.start(&error)) << error;
  const auto* e = sim.daemon.names().table().find("world");
  ASSERT_NE(e, nullptr);
  const std::string data = e->endpoints["data_tcp"].as_string();
  namespace df = dca::data_frame;
  const std::string hello = df::encode_hello(
      {{"/intruder", "Out", "world", "base.cmd_vel", "s", dca::Mode::Push, 16}, dca::vector_port("Out", 3)});
  const Eigen::Vector3d v(5, 0, 2);
  const std::string sample(reinterpret_cast<const char*>(v.data()), sizeof(double) * 3);

  dca::test::RawDataClient bare(loop.io(), data);
  ASSERT_TRUE(bare.connected());
  bare.send_frame(df::Kind::Hello, hello);
  bare.send_frame(df::Kind::Sample, sample);
  const auto reply = bare.read_frame();
  ASSERT_TRUE(reply);
  EXPECT_EQ(reply->kind, df::Kind::HelloError);
  EXPECT_NE(reply->body.find("authentication required"), std::string::npos) << reply->body;
  EXPECT_TRUE(bare.wait_closed());

  dca::test::RawDataClient wrong(loop.io(), data);
  ASSERT_TRUE(wrong.connected());
  EXPECT_NE(wrong.handshake(dca::data_key("another cluster's key 0123456789")), "");
  wrong.send_frame(df::Kind::Hello, hello);
  wrong.send_frame(df::Kind::Sample, sample);
  EXPECT_TRUE(wrong.wait_closed());

  auto to_world = open(sim, sim.control_of("world"));
  ASSERT_TRUE(to_world);
  const Value ports = call(sim, to_world, "ports");
  EXPECT_EQ(ports["refused"].as_int(), 2);
  EXPECT_EQ(ports["accepted"].as_int(), 0);
  for (const auto& in : ports["inputs"].as_array())
    if (in["name"].as_string() == "base.cmd_vel") {
      EXPECT_EQ(in["samples"].as_int(), 0) << "a sample got in";
    }
  sim.stop("test over");
}

}  // namespace

// The emergency stop (docs/safety.md): pressed at 0.5 s, the base's command in force is zero from the next step
// whatever the driver writes, its samples still counted; the release names it, and a second press is no new one.
TEST_F(WorldNodeTest, AnEmergencyStopZeroesTheCommandsFromTheNextStep) {
  Value pressed, again, bad;
  const auto r = run_once(1.0, false, [&](dca::test::SimWorld& sim, const dca::Channel::Ptr& to_world) {
    EXPECT_EQ(call(sim, to_world, "status")["base_cmd"].as_array()[0].as_float(), 0.2);
    pressed = call(sim, to_world, "estop", Value::map().set("source", "test"));
    again = call(sim, to_world, "estop", Value::map().set("source", "test again"));
    const auto wrong = sim.call(to_world, "release", Value::map().set("what", "brakes"));
    bad = Value(wrong.error);
  });
  EXPECT_EQ(pressed["t"].as_float(), 0.5);
  EXPECT_FALSE(pressed["already"].as_bool());
  EXPECT_TRUE(again["already"].as_bool());
  EXPECT_EQ(again["source"].as_string(), "test");
  EXPECT_NE(bad.as_string().find("name what to release"), std::string::npos) << bad.as_string();
  ASSERT_EQ(r.ticks, 100);  // the driver ran on, writing
  for (const auto& v : r.status["base_cmd"].as_array()) EXPECT_EQ(v.as_float(), 0.0);
  EXPECT_NEAR(r.x, 0.2 * 0.49, 0.03);  // it stopped at the press (not 0.2 * 0.99)
  const Value& e = r.status["estop"];
  EXPECT_TRUE(e["latched"].as_bool());
  EXPECT_EQ(e["source"].as_string(), "test");
  EXPECT_EQ(e["presses"].as_int(), 1);
  EXPECT_EQ(e["held_samples"].as_int(), 50);  // every sample of 0.5 s at 10 ms, kept from the world
  ASSERT_EQ(r.status["estop_log"].as_array().size(), 1u);
  EXPECT_EQ(r.status["estop_log"].as_array()[0].as_string(), "pressed at 0.500 s by test");
}
