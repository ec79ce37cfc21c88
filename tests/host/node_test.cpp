// The node runtime: start-up against a daemon (a minimal stand-in here: ping/register/lookup over a real
// authenticated channel), the control requests, DONE/ABORTED/broken events, data between two nodes.
#include "host/node.h"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <optional>

#include "host/net/auth.h"
#include "host/net/channel.h"
#include "host/rt/contract.h"

namespace {

using namespace std::chrono_literals;
using dca::wire::Message;
using dca::wire::Value;

// A component with a scalar output Out and a scalar input In; finish() ends its run.
class TestComponent final : public dca::Component {
 public:
  explicit TestComponent(std::string name) : name_(std::move(name)) {
    out = &ports_.add_output(dca::scalar_port("Out"));
    in = &ports_.add_input(dca::scalar_port("In"));
  }
  const std::string& name() const override { return name_; }
  dca::PortSet& ports() override { return ports_; }
  bool configure(std::string* error) override {
    ++inits;
    if (fail_init && error) *error = "cannot init: told to fail";
    return !fail_init;
  }
  bool start(dca::Bytes init_value, std::string*) override {
    running = true;
    last_init = dca::value_from_msgpack(init_value);
    if (timers && period > 0) timer = timers->every(period, [this] { ++ticks; }, name_);
    return true;
  }
  void halt() override {
    running = false;
    if (timer) timers->cancel(timer);
    timer = 0;
  }
  void finish(dca::ComponentEvent e) {
    if (!running) return;
    running = false;
    on_event(e);
  }
  dca::Output* out = nullptr;
  dca::Input* in = nullptr;
  int inits = 0;
  bool fail_init = false, running = false;
  Value last_init;
  dca::TimerServer* timers = nullptr;  // with a period: a periodic component (ticks while running)
  dca::Nanos period = 0;
  dca::TimerServer::Id timer = 0;
  std::vector<std::string> args;
  int ticks = 0;

 private:
  std::string name_;
  dca::PortSet ports_;
};

// A periodic link of a chain for the real-time thread (host/node_rt.h): each tick notes the thread it runs on,
// takes In's newest sample (pushed, or a pull connection's answer to the request of its last tick) and writes
// Out = that sample + 1 (its tick count before any); a negative sample aborts its run. One named /slow... runs
// 5.5 periods long at its first tick. Read from the test's thread while it runs: atomics.
class ChainComponent final : public dca::Component {
 public:
  ChainComponent(std::string name, dca::TimerServer& ts) : name_(std::move(name)), timers_(ts) {
    out_ = &ports_.add_output(dca::scalar_port("Out"));
    in_ = &ports_.add_input(dca::scalar_port("In"));
  }
  const std::string& name() const override { return name_; }
  dca::PortSet& ports() override { return ports_; }
  bool configure(std::string*) override { return true; }
  bool start(dca::Bytes, std::string*) override {
    running = true;
    timer_ = timers_.every(1'000'000, [this] { tick(); }, name_);
    return true;
  }
  void halt() override {
    running = false;
    if (timer_) timers_.cancel(timer_);
    timer_ = 0;
  }
  std::atomic<long> tid{0};
  std::atomic<int> ticks{0};
  std::atomic<int> first_queued{-1};  // the samples queued on In at its first tick
  std::atomic<bool> running{false};

 private:
  void tick() {
    tid.store(static_cast<long>(::gettid()));
    const int n = ticks.load() + 1;
    ticks.store(n);
    if (n == 1) first_queued.store(static_cast<int>(in_->queued()));
    if (n == 1 && name_.rfind("/slow", 0) == 0) {
      const timespec ts{0, 5'500'000};
      nanosleep(&ts, nullptr);
    }
    in_->take_latest();
    if (in_->has_current()) last_ = in_->scalar();
    in_->request();  // (a pull connection's answer, if any, for the next tick)
    if (last_ < 0) {
      halt();
      return on_event({dca::ComponentEvent::Kind::Aborted, "", "negative"});
    }
    out_->write(last_ > 0 ? last_ + 1 : n);
  }
  std::string name_;
  dca::TimerServer& timers_;
  dca::PortSet ports_;
  dca::Output* out_ = nullptr;
  dca::Input* in_ = nullptr;
  double last_ = 0;
  dca::TimerServer::Id timer_ = 0;
};

class NodeTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir = std::filesystem::temp_directory_path() / ("dca-node-test-" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    key_file = (dir / "key").string();
    std::string error;
    auto key = dca::auth::load_or_create_key(key_file, &error);
    ASSERT_TRUE(key) << error;
    opts.key = *key;
    // The daemon stand-in: ping, register, lookup (waiting), as host "h".
    daemon = dca::Listener::listen(loop.io(), *dca::Address::parse("127.0.0.1:0"), opts,
                                   [this](dca::Channel::Ptr ch) {
                                     daemon_channels.push_back(ch);
                                     ch->on_message([this, ch](const Message& m) { serve(ch, m); });
                                   },
                                   &error);
    ASSERT_TRUE(daemon) << error;
  }
  void TearDown() override {
    nodes.clear();
    for (auto& ch : daemon_channels) ch->close();
    if (daemon) daemon->close();
    std::error_code ec;
    std::filesystem::remove_all(dir, ec);
  }
  void serve(const dca::Channel::Ptr& ch, const Message& m) {
    if (m.type == "ping") return void(ch->reply(m, Value::map().set("host", "h").set("pid", 1)));
    if (m.type == "register" && hold_register) return void(++held);  // never answered
    if (m.type == "register") {
      names[m.payload["name"].as_string()] = m.payload["endpoints"];
      return void(ch->reply(m, Value::map().set("name", m.payload["name"]).set("host", "h")));
    }
    if (m.type == "unregister") {
      names.erase(m.payload["name"].as_string());
      return void(ch->reply(m));
    }
    if (m.type == "lookup") {
      auto it = names.find(m.payload["name"].as_string());
      if (it == names.end()) return void(ch->reply_error(m, "no name '" + m.payload["name"].as_string() + "'"));
      return void(ch->reply(m, Value::map().set("name", it->first).set("endpoints", it->second).set("host", "h")));
    }
    ch->reply_error(m, "unknown request");
  }
  bool run_until(const std::function<bool()>& pred) { return loop.run_until(pred, 5s); }

  // The options of a node named `name` on the stand-in daemon; with `sim`, on a simulated clock with no master.
  dca::NodeOptions node_options(const std::string& name, bool sim) const {
    dca::NodeOptions o;
    o.name = name;
    o.daemon = daemon->address().str();
    o.key_file = key_file;
    if (sim) {
      o.clock = dca::ClockKind::Simulated;
      o.world = "";
    }
    return o;
  }

  // Starts a node hosting a TestComponent named `name`; returns the component.
  // With a period, the component ticks on a periodic timer while it runs; with `sim`, the node is on a
  // simulated clock with no master (any control channel advances it).
  TestComponent* start_node(const std::string& name, dca::Nanos period = 0, bool sim = false) {
    dca::NodeOptions o = node_options(name, sim);
    o.type = "Test";
    TestComponent* made = nullptr;
    nodes.push_back(std::make_unique<dca::Node>(
        loop, o,
        [&made, period](const std::string&, const std::string& n, const std::string& host,
                        const std::vector<std::string>&, dca::TimerServer& ts) {
          EXPECT_EQ(host, "h");  // learnt from the daemon's ping
          auto c = std::make_unique<TestComponent>(n);
          c->timers = &ts;
          c->period = period;
          made = c.get();
          return c;
        }));
    std::optional<std::string> result;
    nodes.back()->start([&](const std::string& e) { result = e; });
    EXPECT_TRUE(run_until([&] { return result.has_value(); }));
    EXPECT_EQ(result.value_or("timeout"), "");
    return made;
  }

  // Starts a node with options `o` whose leaves are ChainComponents (each kept in *made by its PATH, if given);
  // returns the last one made (a one-leaf node's).
  ChainComponent* start_chain(const dca::NodeOptions& o, std::map<std::string, ChainComponent*>* made = nullptr) {
    // the node keeps the factory and makes leaves added later with it: what it writes outlives this call
    auto last = std::make_shared<ChainComponent*>(nullptr);
    nodes.push_back(std::make_unique<dca::Node>(loop, o, [last, made](const std::string&, const std::string& n,
        const std::string&, const std::vector<std::string>&, dca::TimerServer& ts) {
      auto c = std::make_unique<ChainComponent>(n, ts);
      *last = c.get();
      if (made) (*made)[n] = c.get();
      return c;
    }));
    std::optional<std::string> started;
    nodes.back()->start([&](const std::string& e) { started = e; });
    EXPECT_TRUE(run_until([&] { return started.has_value(); }));
    EXPECT_EQ(started.value_or("timeout"), "");
    return *last;
  }

  // Starts a one-leaf node `name` on the wall clock whose ChainComponent runs on a real-time thread (pinned to CPU
  // 0, the default scheduler, memory not locked).
  ChainComponent* start_rt_chain(const std::string& name) {
    dca::NodeOptions o = node_options(name, false);
    o.type = "Chain";
    o.rt.cpu = 0;
    o.rt.lock_memory = false;
    return start_chain(o);
  }

  // Starts a shared node named `name` (registered as name#PID) whose leaves are TestComponents kept in `made`
  // (the latest instance of each PATH; `created` counts them); type "Bad" is refused as an unknown type.
  void start_shared(const std::string& name, dca::Nanos period = 0, bool sim = false) {
    dca::NodeOptions o = node_options(name, sim);
    o.shared = true;
    o.load_package = [](const std::string&, const std::string&, std::string*) { return true; };
    o.package_changed = [this](const std::string& package, const std::string& system_dir) {
      packages_asked.push_back(package + " " + system_dir);
      return changed;
    };
    nodes.push_back(std::make_unique<dca::Node>(
        loop, o,
        [this, period](const std::string& type, const std::string& n, const std::string&,
                       const std::vector<std::string>& args, dca::TimerServer& ts) {
          if (type == "Bad") throw std::invalid_argument("unknown controller type 'Bad'");
          auto c = std::make_unique<TestComponent>(n);
          c->timers = &ts;
          c->period = period;
          c->args = args;
          shared_made[n] = c.get();
          ++created;
          return c;
        }));
    std::optional<std::string> result;
    nodes.back()->start([&](const std::string& e) { result = e; });
    ASSERT_TRUE(run_until([&] { return result.has_value(); }));
    ASSERT_EQ(result.value_or("timeout"), "");
  }

  // A shared node (start_shared) hosting `leaves` of type Test: the channel to its own control address.
  dca::Channel::Ptr shared_with(const std::vector<std::string>& leaves, dca::Nanos period = 0, bool sim = false) {
    start_shared("leaves@h", period, sim);
    auto proc = supervise("leaves@h#" + std::to_string(::getpid()));
    for (const auto& n : leaves) {
      const auto r = call(proc, "add", Value::map().set("controller", "Test").set("name", n).set("args", Value::array()));
      EXPECT_TRUE(r.ok()) << r.error;
    }
    return proc;
  }

  // A supervisor's channel to the node registered as `name`.
  dca::Channel::Ptr supervise(const std::string& name) {
    EXPECT_TRUE(names.count(name));
    dca::Channel::Ptr ch;
    std::string err = "pending";
    dca::Channel::connect(loop.io(), *dca::Address::parse(names[name]["control"].as_string()), opts,
                          [&](dca::Channel::Ptr c, const std::string& e) {
                            ch = c;
                            err = e;
                          });
    EXPECT_TRUE(run_until([&] { return err != "pending"; }));
    EXPECT_TRUE(ch) << err;
    if (ch) ch->on_message([this](const Message& m) { events.push_back(m); });
    return ch;
  }

  dca::Response call(const dca::Channel::Ptr& ch, const std::string& type, Value payload = Value::map()) {
    std::optional<dca::Response> r;
    ch->request({type, 0, std::move(payload)}, 3s, [&](dca::Response x) { r = std::move(x); });
    EXPECT_TRUE(run_until([&] { return r.has_value(); }));
    return r.value_or(dca::Response{});
  }

  dca::Loop loop;
  std::filesystem::path dir;
  std::string key_file;
  dca::ChannelOptions opts;
  dca::Listener::Ptr daemon;
  std::vector<dca::Channel::Ptr> daemon_channels;
  std::map<std::string, Value> names;
  std::vector<std::unique_ptr<dca::Node>> nodes;
  std::vector<Message> events;
  std::map<std::string, TestComponent*> shared_made;  // a shared node's leaves (start_shared)
  int created = 0;
  // a shared node's packages (start_shared): each `add` naming one loads it; package_changed answers `changed`
  std::vector<std::string> packages_asked;
  std::string changed;
  bool hold_register = false;  // the stand-in daemon leaves register requests unanswered (counted in held)
  int held = 0;
};

TEST_F(NodeTest, RegistersItsEndpointsWithTheDaemon) {
  start_node("/sys/a");
  ASSERT_TRUE(names.count("/sys/a"));
  const auto& e = names["/sys/a"];
  EXPECT_EQ(e["host"].as_string(), "h");
  EXPECT_EQ(e["pid"].as_int(), ::getpid());
  EXPECT_EQ(e["type"].as_string(), "Test");
  EXPECT_FALSE(e["control"].as_string().empty());
  EXPECT_FALSE(e["data_uds"].as_string().empty());
  EXPECT_EQ(e["data_tcp"].as_string().rfind("127.0.0.1:", 0), 0u);
}

TEST_F(NodeTest, InitRunStopAndDoneEvent) {
  auto* c = start_node("/sys/a");
  auto sup = supervise("/sys/a");
  EXPECT_TRUE(call(sup, "init").ok());
  EXPECT_EQ(c->inits, 1);
  EXPECT_TRUE(call(sup, "run", Value::map().set("init", 42)).ok());
  EXPECT_TRUE(c->running);
  EXPECT_EQ(c->last_init, Value(42));
  msgpack::sbuffer sb;
  msgpack::pack(sb, std::string("timeout"));
  c->finish({dca::ComponentEvent::Kind::Done, std::string(sb.data(), sb.size()), ""});
  ASSERT_TRUE(run_until([&] { return !events.empty(); }));
  EXPECT_EQ(events[0].type, "done");
  EXPECT_EQ(events[0].payload["name"].as_string(), "/sys/a");
  EXPECT_EQ(events[0].payload["value"].as_string(), "timeout");
  EXPECT_TRUE(call(sup, "run").ok());
  c->finish({dca::ComponentEvent::Kind::Aborted, "", "hit the wall"});
  ASSERT_TRUE(run_until([&] { return events.size() == 2; }));
  EXPECT_EQ(events[1].type, "aborted");
  EXPECT_EQ(events[1].payload["reason"].as_string(), "hit the wall");
  EXPECT_TRUE(call(sup, "stop").ok());
}

TEST_F(NodeTest, InitFailureIsAnErrorReply) {
  auto* c = start_node("/sys/a");
  c->fail_init = true;
  auto sup = supervise("/sys/a");
  const auto r = call(sup, "init");
  EXPECT_EQ(r.error, "cannot init: told to fail");
}

TEST_F(NodeTest, ConnectsTwoNodesByNameAndSwitchesTheSet) {
  auto* a = start_node("/sys/a");
  auto* b = start_node("/sys/b");
  auto sa = supervise("/sys/a");
  auto sb = supervise("/sys/b");
  auto r = call(sa, "connect", Value::map().set("out", "Out").set("to", "/sys/b").set("in", "In").set("set", "g:a[l]"));
  ASSERT_TRUE(r.ok()) << r.error;
  EXPECT_EQ(r.message.payload["transport"].as_string(), "unix");  // same host, another process's endpoint
  a->out->write(1.0);  // inactive: nothing
  ASSERT_TRUE(call(sa, "activate", Value::map().set("set", "g:a[l]")).ok());
  a->out->write(2.0);
  ASSERT_TRUE(run_until([&] { return b->in->stats().samples == 1; }));
  r = call(sb, "read", Value::map().set("port", "In"));
  ASSERT_TRUE(r.ok()) << r.error;
  EXPECT_EQ(r.message.payload["value"].as_float(), 2.0);
  EXPECT_EQ(r.message.payload["count"].as_int(), 1);
  ASSERT_TRUE(call(sa, "deactivate", Value::map().set("set", "g:a[l]")).ok());
  a->out->write(3.0);
  r = call(sa, "ports");
  ASSERT_TRUE(r.ok());
  const auto& links = r.message.payload["links"].as_array();
  ASSERT_EQ(links.size(), 1u);
  EXPECT_EQ(links[0]["skipped"].as_int(), 2);
  EXPECT_EQ(links[0]["sent"].as_int(), 1);
  EXPECT_EQ(links[0]["active"].as_bool(), false);
  EXPECT_EQ(b->in->stats().samples, 1u);
}

TEST_F(NodeTest, PullAnswersWithTheSourcesLatestSample) {
  auto* a = start_node("/sys/a");
  start_node("/sys/b");
  auto sa = supervise("/sys/a");
  auto sb = supervise("/sys/b");
  auto r = call(sa, "connect",
                Value::map().set("out", "Out").set("to", "/sys/b").set("in", "In").set("set", "p").set("mode", "pull"));
  ASSERT_TRUE(r.ok()) << r.error;
  ASSERT_TRUE(call(sa, "activate", Value::map().set("set", "p")).ok());
  a->out->write(5.0);
  a->out->write(6.0);
  r = call(sb, "pull", Value::map().set("port", "In"));
  ASSERT_TRUE(r.ok()) << r.error;
  EXPECT_EQ(r.message.payload["value"].as_float(), 6.0);
  EXPECT_EQ(r.message.payload["count"].as_int(), 1);  // nothing was pushed: only the answer arrived
  ASSERT_TRUE(call(sa, "deactivate", Value::map().set("set", "p")).ok());
  r = call(sb, "pull", Value::map().set("port", "In").set("timeout_ms", 50));
  EXPECT_EQ(r.error, "pull: no sample arrived at /sys/b.In in time");  // an inactive set answers nothing
}

TEST_F(NodeTest, ConnectErrorsNameTheValidPorts) {
  start_node("/sys/a");
  start_node("/sys/b");
  auto sa = supervise("/sys/a");
  auto r = call(sa, "connect", Value::map().set("out", "Out").set("to", "/sys/b").set("in", "Inn").set("set", "s"));
  EXPECT_EQ(r.error, "no input 'Inn' on /sys/b; inputs are: In");
  r = call(sa, "connect", Value::map().set("out", "Oot").set("to", "/sys/b").set("in", "In").set("set", "s"));
  EXPECT_EQ(r.error, "no output 'Oot' on /sys/a; outputs are: Out");
  r = call(sa, "connect", Value::map().set("out", "Out").set("to", "/nobody").set("in", "In").set("set", "s"));
  EXPECT_EQ(r.error, "connect: cannot find /nobody: no name '/nobody'");
  r = call(sa, "read", Value::map().set("port", "X"));
  EXPECT_EQ(r.error, "no port 'X' on /sys/a; ports are: Out, In");
  r = call(sa, "frobnicate");
  EXPECT_EQ(r.error, "unknown request 'frobnicate' for node /sys/a");
  r = call(sa, "advance", Value::map().set("t", 5));
  EXPECT_EQ(r.error, "advance: node /sys/a runs on the wall clock");
}

TEST_F(NodeTest, BrokenDataConnectionIsAnEventAtTheSupervisor) {
  auto* a = start_node("/sys/a");
  start_node("/sys/b");
  auto sa = supervise("/sys/a");
  ASSERT_TRUE(call(sa, "connect", Value::map().set("out", "Out").set("to", "/sys/b").set("in", "In").set("set", "s")).ok());
  nodes[1]->shutdown("test");  // /sys/b goes away
  ASSERT_TRUE(run_until([&] { return !events.empty(); }));
  EXPECT_EQ(events[0].type, "broken");
  EXPECT_EQ(events[0].payload["port"].as_string(), "Out");
  EXPECT_EQ(events[0].payload["peer"].as_string(), "/sys/b.In");
  EXPECT_EQ(events[0].payload["set"].as_string(), "s");
  a->out->write(1.0);  // never blocks
}

TEST_F(NodeTest, LosingTheDaemonStopsTheNode) {
  auto* c = start_node("/sys/a");
  auto sa = supervise("/sys/a");
  ASSERT_TRUE(call(sa, "run").ok());
  for (auto& ch : daemon_channels) ch->close("daemon stopping");
  ASSERT_TRUE(run_until([&] { return nodes[0]->finished(); }));
  EXPECT_FALSE(c->running);  // stopped: actuators safe
  EXPECT_EQ(nodes[0]->exit_code(), 1);
}

TEST_F(NodeTest, StatsReportThePeriodsAchievedOnTheNodesClockAndTheWallClock) {
  constexpr dca::Nanos kMs = 1'000'000;
  auto* c = start_node("/sys/motion", kMs, true);
  auto sup = supervise("/sys/motion");
  ASSERT_TRUE(call(sup, "run").ok());
  for (int k = 1; k <= 50; ++k) {  // the master's lock-step, one millisecond a round
    const auto r = call(sup, "advance", Value::map().set("t", k * kMs));
    ASSERT_TRUE(r.ok()) << r.error;
    EXPECT_EQ(r.message.payload["next"].as_int(), (k + 1) * kMs);
  }
  EXPECT_EQ(c->ticks, 50);
  ASSERT_TRUE(call(sup, "stop").ok());  // figures stay after the run
  const auto r = call(sup, "stats");
  ASSERT_TRUE(r.ok()) << r.error;
  const auto& p = r.message.payload;
  EXPECT_EQ(p["clock"].as_string(), "sim");
  ASSERT_EQ(p["intervals"].as_array().size(), 1u);
  const auto& iv = p["intervals"].as_array()[0];
  EXPECT_EQ(iv["name"].as_string(), "/sys/motion");
  EXPECT_DOUBLE_EQ(iv["period_s"].as_float(), 0.001);
  EXPECT_EQ(iv["clock"]["n"].as_int(), 49);
  for (const char* q : {"p50_us", "p99_us", "p999_us", "max_us", "min_us", "mean_us"})
    EXPECT_DOUBLE_EQ(iv["clock"][q].as_float(), 1000.0) << q;
  EXPECT_EQ(iv["wall"]["n"].as_int(), 49);
  EXPECT_LE(iv["wall"]["p50_us"].as_float(), iv["wall"]["p99_us"].as_float());
  EXPECT_LE(iv["wall"]["p99_us"].as_float(), iv["wall"]["max_us"].as_float());
  EXPECT_GT(iv["wall"]["min_us"].as_float(), 0.0);
  ASSERT_EQ(p["timers"].as_array().size(), 1u);  // the lateness of the same timer, as before
  EXPECT_EQ(p["timers"].as_array()[0]["count"].as_int(), 50);
}

// A shared node (dca run --placement group|host): leaves added at run time, each with its own control address,
// events and registration; connections between them in process; one advance for all of them.
TEST_F(NodeTest, SharedNodeGivesEachLeafItsOwnControlEventsAndRegistration) {
  start_shared("leaves@h");
  const std::string self = "leaves@h#" + std::to_string(::getpid());
  ASSERT_TRUE(names.count(self));
  EXPECT_EQ(names[self]["shared"].as_bool(), true);
  auto proc = supervise(self);
  auto r = call(proc, "add", Value::map().set("controller", "Test").set("name", "/g/a").set("args", Value::Array{"1.5"}));
  ASSERT_TRUE(r.ok()) << r.error;
  ASSERT_TRUE(call(proc, "add", Value::map().set("controller", "Test").set("name", "/g/b").set("args", Value::array())).ok());
  EXPECT_EQ(nodes[0]->leaves(), 2u);
  EXPECT_EQ(shared_made["/g/a"]->args, std::vector<std::string>{"1.5"});
  // registered under their paths: their own control addresses, the process's data endpoint and pid
  ASSERT_TRUE(names.count("/g/a") && names.count("/g/b"));
  EXPECT_EQ(r.message.payload["control"].as_string(), names["/g/a"]["control"].as_string());
  EXPECT_NE(names["/g/a"]["control"].as_string(), names["/g/b"]["control"].as_string());
  EXPECT_EQ(names["/g/a"]["data_uds"].as_string(), names["/g/b"]["data_uds"].as_string());
  EXPECT_EQ(names["/g/a"]["pid"].as_int(), ::getpid());
  EXPECT_EQ(names["/g/a"]["shared"].as_string(), self);
  EXPECT_EQ(names["/g/b"]["type"].as_string(), "Test");
  auto sa = supervise("/g/a");
  std::vector<Message> a_events;
  sa->on_message([&](const Message& m) { a_events.push_back(m); });
  auto sb = supervise("/g/b");
  ASSERT_TRUE(call(sa, "run", Value::map().set("init", 1)).ok());
  ASSERT_TRUE(call(sb, "run").ok());
  EXPECT_TRUE(shared_made["/g/a"]->running && shared_made["/g/b"]->running);
  shared_made["/g/b"]->finish({dca::ComponentEvent::Kind::Aborted, "", "b failed"});
  ASSERT_TRUE(run_until([&] { return !events.empty(); }));
  EXPECT_EQ(events[0].type, "aborted");  // on b's channel only
  EXPECT_EQ(events[0].payload["name"].as_string(), "/g/b");
  EXPECT_TRUE(a_events.empty());
  EXPECT_TRUE(shared_made["/g/a"]->running);
  EXPECT_EQ(call(sa, "read", Value::map().set("port", "X")).error, "no port 'X' on /g/a; ports are: Out, In");
  EXPECT_EQ(call(sb, "frobnicate").error, "unknown request 'frobnicate' for node /g/b");
}

TEST_F(NodeTest, LeavesOfASharedNodeConnectInProcessAndListTheirOwnLinks) {
  auto proc = shared_with({"/g/a", "/g/b"});
  auto sa = supervise("/g/a");
  auto sb = supervise("/g/b");
  auto r = call(sa, "connect", Value::map().set("out", "Out").set("to", "/g/b").set("in", "In").set("set", "g:a[l]"));
  ASSERT_TRUE(r.ok()) << r.error;
  EXPECT_EQ(r.message.payload["transport"].as_string(), "inprocess");
  ASSERT_TRUE(call(sa, "activate", Value::map().set("set", "g:a[l]")).ok());
  shared_made["/g/a"]->out->write(4.0);
  EXPECT_EQ(shared_made["/g/b"]->in->stats().samples, 1u);  // handed over directly: no socket, no loop turn
  EXPECT_EQ(call(sa, "ports").message.payload["links"].as_array().size(), 1u);
  EXPECT_EQ(call(sb, "ports").message.payload["links"].as_array().size(), 0u);
  r = call(sb, "read", Value::map().set("port", "In"));
  EXPECT_EQ(r.message.payload["value"].as_float(), 4.0);
}

// code {}, which a restart asks first: the process a leaf runs in and, for a leaf added with a package, whether the
// package's file is still the one the process loaded (NodeOptions::package_changed).
TEST_F(NodeTest, CodeSaysALeafsProcessAndWhetherItsPackageChanged) {
  auto proc = shared_with({"/g/a"});
  ASSERT_TRUE(call(proc, "add", Value::map().set("controller", "Test").set("name", "/g/b").set("args", Value::array())
                                    .set("package", "pkg").set("system_dir", "/sys")).ok());
  const std::string self = "leaves@h#" + std::to_string(::getpid());
  auto sa = supervise("/g/a");
  auto sb = supervise("/g/b");
  auto a = call(sa, "code").message.payload;
  EXPECT_EQ(a["shared"].as_string(), self);
  EXPECT_EQ(a["pid"].as_int(), ::getpid());
  EXPECT_EQ(a["leaves"].as_int(), 2);
  EXPECT_TRUE(a["package"].is_nil());  // a built-in's code changes with dca only
  auto b = call(sb, "code").message.payload;
  EXPECT_EQ(b["package"].as_string(), "pkg");
  EXPECT_TRUE(b["changed"].is_nil());
  changed = "/sys/packages/pkg.dca.so changed on disk since this process loaded it";
  b = call(sb, "code").message.payload;
  EXPECT_EQ(b["changed"].as_string(), changed);
  EXPECT_EQ(packages_asked, (std::vector<std::string>{"pkg /sys", "pkg /sys"}));
  // a one-leaf node: no shared process
  start_node("/solo");
  auto solo = call(supervise("/solo"), "code").message.payload;
  EXPECT_TRUE(solo["shared"].is_nil());
  EXPECT_EQ(solo["leaves"].as_int(), 1);
}

// restart(path) of a leaf in a shared node: remove, then add the same PATH: a fresh instance in the same
// process, while its neighbour runs on.
TEST_F(NodeTest, RemoveThenAddOfALeafIsAFreshInstanceInTheSameProcess) {
  auto proc = shared_with({"/g/a", "/g/b"});
  auto sa = supervise("/g/a");
  auto sb = supervise("/g/b");
  ASSERT_TRUE(call(sb, "run").ok());
  ASSERT_TRUE(call(sa, "init").ok());
  bool closed = false;
  sa->on_close([&](const std::string&) { closed = true; });
  auto* old = shared_made["/g/a"];
  ASSERT_TRUE(call(proc, "remove", Value::map().set("name", "/g/a")).ok());
  ASSERT_TRUE(run_until([&] { return closed && !names.count("/g/a"); }));
  EXPECT_EQ(nodes[0]->leaves(), 1u);
  EXPECT_EQ(call(proc, "remove", Value::map().set("name", "/g/a")).error,
            "remove: /g/a is not hosted by node leaves@h#" + std::to_string(::getpid()));
  ASSERT_TRUE(call(proc, "add", Value::map().set("controller", "Test").set("name", "/g/a").set("args", Value::array())).ok());
  EXPECT_EQ(created, 3);
  EXPECT_NE(shared_made["/g/a"], old);  // (the old one is gone: a fresh one may reuse its address)
  EXPECT_EQ(shared_made["/g/a"]->inits, 0);
  auto sa2 = supervise("/g/a");
  ASSERT_TRUE(call(sa2, "init").ok());
  EXPECT_TRUE(shared_made["/g/b"]->running);
  // errors: the same PATH twice, an unknown type, a leaf's exit ends that leaf only
  EXPECT_EQ(call(proc, "add", Value::map().set("controller", "Test").set("name", "/g/a").set("args", Value::array())).error,
            "/g/a is already hosted by this node");
  EXPECT_EQ(call(proc, "add", Value::map().set("controller", "Bad").set("name", "/g/c").set("args", Value::array())).error,
            "unknown controller type 'Bad'");
  EXPECT_EQ(call(proc, "add", Value::map().set("controller", "Test").set("name", "/g/c").set("args", Value::array())
                                  .set("package", "door").set("system_dir", "rel")).error,
            "add: system_dir 'rel' is not absolute");
  ASSERT_TRUE(call(sa2, "exit").ok());
  ASSERT_TRUE(run_until([&] { return nodes[0]->leaves() == 1u; }));
  EXPECT_FALSE(nodes[0]->finished());
}

// A shared node shutting down while an add waits for its registration: closing the daemon channel answers that
// request at once, with an error, after shutdown let go of the data endpoint; undoing the add must not touch it.
TEST_F(NodeTest, ShutdownWhileAnAddWaitsForItsRegistrationIsSafe) {
  auto proc = shared_with({});
  hold_register = true;
  std::optional<dca::Response> r;
  proc->request({"add", 0, Value::map().set("controller", "Test").set("name", "/g/a").set("args", Value::array())}, 3s,
                [&](dca::Response x) { r = std::move(x); });
  ASSERT_TRUE(run_until([&] { return held == 1; }));
  EXPECT_EQ(nodes[0]->leaves(), 1u);
  nodes[0]->shutdown("test");
  ASSERT_TRUE(run_until([&] { return r.has_value(); }));
  EXPECT_FALSE(r->ok());
}

TEST_F(NodeTest, OneAdvanceRunsTheTimersOfEveryLeafOfASharedNode) {
  constexpr dca::Nanos kMs = 1'000'000;
  auto proc = shared_with({"/g/a", "/g/b"}, kMs, true);
  auto sa = supervise("/g/a");
  auto sb = supervise("/g/b");
  ASSERT_TRUE(call(sa, "run").ok());
  ASSERT_TRUE(call(sb, "run").ok());
  for (int k = 1; k <= 5; ++k) ASSERT_TRUE(call(proc, "advance", Value::map().set("t", k * kMs)).ok());
  EXPECT_EQ(shared_made["/g/a"]->ticks, 5);
  EXPECT_EQ(shared_made["/g/b"]->ticks, 5);
  const auto r = call(sa, "stats");  // a leaf's own timers only
  ASSERT_EQ(r.message.payload["timers"].as_array().size(), 1u);
  EXPECT_EQ(r.message.payload["timers"].as_array()[0]["name"].as_string(), "/g/a");
}

// A node with an rt setting runs its leaves on a real-time thread of its own (host/node_rt.h): here a shared node
// with a chain a -> b (linked in process: on that thread), fed from another node's output over a socket. Without the privilege (CI) it warns and runs
// the thread under the default scheduler: the same thread still, apart from the I/O thread (this one).
TEST_F(NodeTest, RtSettingRunsTheLeavesOnARealTimeThreadSamplesCrossBothWays) {
  ASSERT_TRUE(dca::rt::contract::hooked());  // tests/support/rt_hooks.cpp is linked in
  auto* x = start_node("/x");
  dca::NodeOptions o = node_options("rt@h", false);
  o.shared = true;
  o.rt.priority = 80;
  o.rt.lock_memory = false;  // (mlockall would stay for the rest of this test executable)
  std::map<std::string, ChainComponent*> made;
  start_chain(o, &made);
  auto proc = supervise("rt@h#" + std::to_string(::getpid()));
  for (const char* n : {"/g/a", "/g/b"})
    ASSERT_TRUE(call(proc, "add", Value::map().set("controller", "Chain").set("name", n).set("args", Value::array())).ok());
  auto sa = supervise("/g/a"), sb = supervise("/g/b"), sx = supervise("/x");
  auto link = [&](const dca::Channel::Ptr& ch, const std::string& to, const std::string& set, const char* transport) {
    auto r = call(ch, "connect", Value::map().set("out", "Out").set("to", to).set("in", "In").set("set", set));
    ASSERT_TRUE(r.ok()) << r.error;
    EXPECT_EQ(r.message.payload["transport"].as_string(), transport);
    ASSERT_TRUE(call(ch, "activate", Value::map().set("set", set)).ok());
  };
  link(sa, "/g/b", "g:a[l]", "inprocess");
  link(sx, "/g/a", "g:x[l]", "unix");
  ASSERT_TRUE(call(sa, "run").ok());
  ASSERT_TRUE(call(sb, "run").ok());
  auto* a = made["/g/a"];
  auto* b = made["/g/b"];
  ASSERT_TRUE(run_until([&] { return a->ticks > 20 && b->ticks > 20; }));
  const long io = static_cast<long>(::gettid());
  EXPECT_NE(a->tid.load(), io);
  EXPECT_EQ(a->tid.load(), b->tid.load());  // one real-time thread for the node's leaves
  // into the thread (x's sample over the socket, to a's mirror, then its ring) and out of it (b's Out, read here)
  x->out->write(41.0);
  const auto read_b = [&] { return call(sb, "read", Value::map().set("port", "Out")).message.payload["value"].as_float(); };
  ASSERT_TRUE(run_until([&] { return read_b() == 43.0; }));
  // steady state: nothing allocated or locked on the thread while samples cross both ways
  const auto contract = [&] { return call(sa, "stats").message.payload["rt"]["contract"]; };
  const auto before = contract();
  const int until = a->ticks + 100;
  for (double v = 100; a->ticks < until; v += 1) {
    x->out->write(v);
    const double want = v + 2;
    ASSERT_TRUE(run_until([&] { return read_b() == want; }));
  }
  const auto after = contract();
  EXPECT_EQ(after["allocations"].as_int(), before["allocations"].as_int());
  EXPECT_EQ(after["locks"].as_int(), before["locks"].as_int());
  // a -> b stayed on the thread: the link counts its samples there, none went through b's mirror
  const auto links = call(sa, "ports").message.payload["links"].as_array();
  ASSERT_EQ(links.size(), 1u);
  EXPECT_TRUE(links[0]["rt"].as_bool());
  EXPECT_GE(links[0]["sent"].as_int(), 100);
  EXPECT_EQ(call(sb, "ports").message.payload["inputs"].as_array()[0]["samples"].as_int(), 0);
  const auto st = call(sa, "stats").message.payload["rt"];
  EXPECT_EQ(st["thread"].as_int(), a->tid.load());
  EXPECT_GE(st["runs"].as_int(), 100);
  EXPECT_DOUBLE_EQ(st["period_s"].as_float(), 0.001);
  EXPECT_GE(st["wake"]["n"].as_int(), 100);
  EXPECT_LE(st["exec"]["p50_us"].as_float(), st["exec"]["max_us"].as_float());
  // a pull connection into the thread: c asks each tick, x's latest sample comes back
  ASSERT_TRUE(call(proc, "add", Value::map().set("controller", "Chain").set("name", "/g/c").set("args", Value::array())).ok());
  auto sc = supervise("/g/c");
  auto r = call(sx, "connect", Value::map().set("out", "Out").set("to", "/g/c").set("in", "In").set("set", "g:x[p]")
                                   .set("mode", "pull"));
  ASSERT_TRUE(r.ok()) << r.error;
  ASSERT_TRUE(call(sx, "activate", Value::map().set("set", "g:x[p]")).ok());
  x->out->write(7.0);
  ASSERT_TRUE(call(sc, "run").ok());
  ASSERT_TRUE(run_until([&] { return call(sc, "read", Value::map().set("port", "Out")).message.payload["value"].as_float() == 8.0; }));
  // the control plane: stop and run again, through the thread's command ring
  ASSERT_TRUE(call(sa, "stop").ok());
  EXPECT_FALSE(a->running);
  const int stopped_at = a->ticks;
  ASSERT_TRUE(call(sa, "run").ok());
  EXPECT_TRUE(a->running);
  ASSERT_TRUE(run_until([&] { return a->ticks > stopped_at + 10; }));
  // an end of run on the thread reaches the supervisor (c, pulling x, aborts on that sample too, at its own tick)
  x->out->write(-1.0);
  ASSERT_TRUE(run_until([&] {
    return std::any_of(events.begin(), events.end(), [](const Message& m) {
      return m.type == "aborted" && m.payload["name"].as_string() == "/g/a";
    });
  }));
  EXPECT_FALSE(a->running);
  EXPECT_TRUE(b->running);
}

// A host's shared node (--placement host) has no rt setting of its own: each `add` names its leaf's group's
// ({priority, cpu}), and the node runs one real-time thread per distinct setting (made at its first leaf). Leaves
// of one setting share its thread and link there; a sample crosses between two threads through the I/O thread;
// a leaf without rt runs on the I/O thread.
TEST_F(NodeTest, SharedNodeRunsEachLeafOnTheRealTimeThreadOfItsAddsSetting) {
  dca::NodeOptions o = node_options("host@h", false);
  o.shared = true;
  o.rt.lock_memory = false;  // (the base of each setting: mlockall would stay for the rest of this executable)
  std::map<std::string, ChainComponent*> made;
  start_chain(o, &made);
  auto proc = supervise("host@h#" + std::to_string(::getpid()));
  const auto cpu0 = Value::map().set("cpu", 0);
  const auto fifo = Value::map().set("priority", 80).set("cpu", 0);
  for (const auto& [n, rt] : std::vector<std::pair<std::string, Value>>{
           {"/a/x", cpu0}, {"/a/y", cpu0}, {"/b/z", fifo}, {"/c/w", Value()}}) {
    auto add = Value::map().set("controller", "Chain").set("name", n).set("args", Value::array());
    if (!rt.is_nil()) add.set("rt", rt);
    ASSERT_TRUE(call(proc, "add", add).ok()) << n;
  }
  auto sx = supervise("/a/x"), sy = supervise("/a/y"), sz = supervise("/b/z"), sw = supervise("/c/w");
  auto link = [&](const dca::Channel::Ptr& ch, const std::string& to, const std::string& set) {
    auto r = call(ch, "connect", Value::map().set("out", "Out").set("to", to).set("in", "In").set("set", set));
    ASSERT_TRUE(r.ok()) << r.error;
    ASSERT_TRUE(call(ch, "activate", Value::map().set("set", set)).ok());
  };
  link(sx, "/a/y", "a:x[l]");  // one thread: linked there
  link(sy, "/b/z", "a:y[l]");  // from one thread to another
  for (const auto& ch : {sx, sy, sz, sw}) ASSERT_TRUE(call(ch, "run").ok());
  ASSERT_TRUE(run_until([&] {
    return std::all_of(made.begin(), made.end(), [](const auto& m) { return m.second->ticks > 5; });
  }));
  const long io = static_cast<long>(::gettid());
  const auto thread = [&](const dca::Channel::Ptr& ch) { return call(ch, "stats").message.payload["rt"]["thread"]; };
  EXPECT_NE(made["/a/x"]->tid.load(), io);
  EXPECT_EQ(made["/a/x"]->tid.load(), made["/a/y"]->tid.load());  // one setting, one thread
  EXPECT_NE(made["/b/z"]->tid.load(), io);
  EXPECT_NE(made["/b/z"]->tid.load(), made["/a/x"]->tid.load());  // another setting, another thread
  EXPECT_EQ(made["/c/w"]->tid.load(), io);                        // no setting: the I/O thread
  EXPECT_EQ(thread(sx).as_int(), made["/a/x"]->tid.load());
  EXPECT_EQ(thread(sz).as_int(), made["/b/z"]->tid.load());
  EXPECT_TRUE(thread(sw).is_nil());
  const auto links = call(sx, "ports").message.payload["links"].as_array();
  ASSERT_EQ(links.size(), 1u);
  EXPECT_TRUE(links[0]["rt"].as_bool());  // x -> y on their thread
  // y's Out (x's + 1) reaches z on the other thread, which writes it + 1: once x stops, both stay put
  ASSERT_TRUE(call(sx, "stop").ok());
  const auto read = [&](const dca::Channel::Ptr& ch) {
    return call(ch, "read", Value::map().set("port", "Out")).message.payload["value"].as_float();
  };
  ASSERT_TRUE(run_until([&] { return read(sz) > 0 && read(sz) == read(sy) + 1; }));
}

// A one-leaf node with an rt setting (dca node --type T --rt-priority P): its leaf on the thread from its start;
// on a simulated clock the setting is ignored (the leaf's timer on the node's own TimerServer, lock-step).
TEST_F(NodeTest, OneLeafNodeRunsItsLeafOnTheRealTimeThreadAndIgnoresItOnASimulatedClock) {
  for (const bool sim : {false, true}) {
    const std::string name = sim ? "/sim" : "/wall";
    dca::NodeOptions o = node_options(name, sim);
    o.type = "Chain";
    o.rt.priority = 80;
    o.rt.lock_memory = false;
    ChainComponent* c = start_chain(o);
    ASSERT_NE(c, nullptr);
    auto sup = supervise(name);
    ASSERT_TRUE(call(sup, "run").ok());
    if (sim) ASSERT_TRUE(call(sup, "advance", Value::map().set("t", 3'000'000)).ok());
    else ASSERT_TRUE(run_until([&] { return c->ticks >= 3; }));
    const auto st = call(sup, "stats").message.payload;
    if (sim) {
      EXPECT_EQ(c->ticks, 3);
      EXPECT_EQ(c->tid.load(), static_cast<long>(::gettid()));  // on the node's own thread
      EXPECT_TRUE(st["rt"].is_nil());
    } else {
      EXPECT_NE(c->tid.load(), static_cast<long>(::gettid()));
      EXPECT_EQ(st["rt"]["thread"].as_int(), c->tid.load());
    }
    ASSERT_TRUE(call(sup, "stop").ok());
  }
}

// A run of 5.5 periods on the real-time thread: the deadlines it went past are skipped and counted missed once
// each (when the next run starts, as its TimerServer skips them), never also from the long run's end. So runs
// and missed periods together never exceed the deadlines gone by (counted from before the start: a bound that
// holds however late the thread wakes; counted twice, they would exceed it by about 4).
TEST_F(NodeTest, RealTimeMissedPeriodsAreCountedOncePerDeadline) {
  ChainComponent* c = start_rt_chain("/slow");
  ASSERT_NE(c, nullptr);
  auto sup = supervise("/slow");
  const dca::Nanos before = dca::monotonic_now();
  ASSERT_TRUE(call(sup, "run").ok());
  ASSERT_TRUE(run_until([&] { return c->ticks >= 3; }));
  const auto st = call(sup, "stats").message.payload["rt"];
  const dca::Nanos gone = (dca::monotonic_now() - before) / 1'000'000 + 1;  // deadlines since the start, at most
  EXPECT_GE(st["overruns"].as_int(), 1);
  EXPECT_GE(st["missed"].as_int(), 4);  // deadlines 2..5 went by during the first run
  EXPECT_LE(st["runs"].as_int() + st["missed"].as_int(), gone);
  ASSERT_TRUE(call(sup, "stop").ok());
}

// A connection with a queue over 16 into a leaf on the real-time thread: the leaf's own input grows to it (with
// the thread paused, at the first sample), not only its mirror's. 40 samples sent before the leaf runs are all
// queued on its input at its first tick (16, the oldest dropped, when only the mirror grew).
TEST_F(NodeTest, RealTimeLeafsInputTakesTheQueueItsConnectionAsks) {
  auto* x = start_node("/x");
  ChainComponent* c = start_rt_chain("/q");
  ASSERT_NE(c, nullptr);
  auto sx = supervise("/x"), sq = supervise("/q");
  auto r = call(sx, "connect", Value::map().set("out", "Out").set("to", "/q").set("in", "In").set("set", "g:x[q]")
                                   .set("queue", 64));
  ASSERT_TRUE(r.ok()) << r.error;
  ASSERT_TRUE(call(sx, "activate", Value::map().set("set", "g:x[q]")).ok());
  for (int i = 1; i <= 40; ++i) x->out->write(static_cast<double>(i));
  const auto mirrored = [&] { return call(sq, "ports").message.payload["inputs"].as_array()[0]["samples"].as_int(); };
  ASSERT_TRUE(run_until([&] { return mirrored() == 40; }));
  ASSERT_TRUE(call(sq, "run").ok());
  ASSERT_TRUE(run_until([&] { return c->ticks >= 1; }));
  EXPECT_EQ(c->first_queued.load(), 40);
  ASSERT_TRUE(call(sq, "stop").ok());
}

TEST_F(NodeTest, ValuesConvertBetweenMsgpackAndWire) {
  const Value v = Value::map().set("a", Value::Array{1, 2.5, "x", Value()}).set("b", true);
  const auto bytes = dca::msgpack_from_value(v);
  EXPECT_EQ(dca::value_from_msgpack({reinterpret_cast<const std::byte*>(bytes.data()), bytes.size()}), v);
  EXPECT_TRUE(dca::value_from_msgpack({}).is_nil());
}

}  // namespace
