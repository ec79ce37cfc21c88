#include "host/config_service.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "host/daemon.h"
#include "tests/support/channel_pair.h"
#include "tests/support/temp_dir.h"

namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using namespace dca::test;  // Address, Channel, ..., kKey

class ConfigServiceTest : public ::testing::Test {
 protected:
  void SetUp() override { ASSERT_FALSE(tmp_.path().empty()); }
  void TearDown() override { daemons_.clear(); }

  dca::DaemonOptions options(const std::string& host, std::vector<Address> peers, std::string listen = "127.0.0.1:0") {
    dca::DaemonOptions o;
    o.host = host;
    o.key = kKey;
    o.listen = *Address::parse(listen);
    o.peers = std::move(peers);
    o.state_dir = (dir_ / host).string();
    o.config_sync_interval = 100ms;
    o.stop_grace = 100ms;
    return o;
  }

  dca::Daemon* start(const dca::DaemonOptions& o) {
    auto d = std::make_unique<dca::Daemon>(loop_.io(), o);
    std::string error;
    EXPECT_TRUE(d->start(&error)) << error;
    daemons_[o.host] = std::move(d);
    return daemons_[o.host].get();
  }

  Channel::Ptr connect(const Address& to) {
    Channel::Ptr out;
    bool done = false;
    Channel::connect(loop_.io(), to, ChannelOptions{kKey}, [&](Channel::Ptr ch, const std::string& e) {
      EXPECT_TRUE(ch) << e;
      out = std::move(ch);
      done = true;
    });
    EXPECT_TRUE(loop_.run_until([&] { return done; }, 10s));
    if (out) out->on_message([this](const Message& m) { events_.push_back(m); });
    return out;
  }

  Response call(const Channel::Ptr& ch, const std::string& type, Value payload = Value::map()) {
    Response r;
    bool done = false;
    ch->request(Message{type, 0, std::move(payload)}, 10s, [&](Response got) {
      r = std::move(got);
      done = true;
    });
    EXPECT_TRUE(loop_.run_until([&] { return done; }, 15s));
    return r;
  }

  Response set(const Channel::Ptr& ch, const std::string& key, Value v) {
    auto r = call(ch, "config_set", Value::map().set("values", Value::map().set(key, std::move(v))));
    EXPECT_TRUE(r.ok()) << r.error;
    return r;
  }

  // The value of key at the daemon behind ch (nil when unknown).
  Value value(const Channel::Ptr& ch, const std::string& key) {
    auto r = call(ch, "config_get", Value::map().set("key", key));
    return r.ok() ? r.message.payload["value"] : Value();
  }

  // Waits (bounded) until every channel sees key = v.
  bool everywhere(const std::vector<Channel::Ptr>& chs, const std::string& key, const Value& v) {
    return loop_.run_until(
        [&] {
          for (const auto& ch : chs) {
            auto* d = daemon_of(ch);
            if (d == nullptr) return false;
            std::string e;
            auto got = d->config()->store()->get(key, &e);
            if (!got || !(got->value == v)) return false;
          }
          return true;
        },
        20s);
  }

  dca::Daemon* daemon_of(const Channel::Ptr& ch) {
    for (auto& [h, d] : daemons_)
      if (d && d->address().str() == ch->peer()) return d.get();
    return nullptr;
  }

  std::string content(const std::string& host) {
    std::string out;
    for (const auto& e : daemons_[host]->config()->store()->list(""))
      out += e.key + "=" + e.value.str() + "@" + e.stamp.str() + "\n";
    return out;
  }

  dca::test::TempDir tmp_{"config_service"};
  fs::path dir_ = tmp_.path();
  dca::Loop loop_;
  std::map<std::string, std::unique_ptr<dca::Daemon>> daemons_;
  std::vector<Message> events_;
};

TEST_F(ConfigServiceTest, GetSetListLogAndErrorsOverTheChannel) {
  auto* d = start(options("h1", {}));
  auto ch = connect(d->address());
  ASSERT_TRUE(ch);
  auto r = call(ch, "config_set", Value::map().set("values", Value::map().set("door.width", 0.9).set("door.stop_distance", 0.45)));
  ASSERT_TRUE(r.ok()) << r.error;
  EXPECT_EQ(r.message.payload["seq"].as_int(), 1);
  EXPECT_EQ(r.message.payload["keys"].as_int(), 2);
  EXPECT_EQ(value(ch, "door.width"), Value(0.9));
  r = call(ch, "config_get", Value::map().set("key", "door.widht"));
  EXPECT_EQ(r.error, "unknown key 'door.widht' (did you mean door.width?) on host h1");
  r = call(ch, "config_set", Value::map().set("values", Value::map().set("door..x", 1)));
  EXPECT_NE(r.error.find("bad key 'door..x'"), std::string::npos) << r.error;
  r = call(ch, "config_set", Value::map());
  EXPECT_NE(r.error.find("config_set needs {values"), std::string::npos) << r.error;
  r = call(ch, "config_list", Value::map().set("prefix", "door"));
  ASSERT_TRUE(r.ok()) << r.error;
  ASSERT_EQ(r.message.payload["entries"].as_array().size(), 2u);
  EXPECT_EQ(r.message.payload["entries"].as_array()[0]["key"], Value("door.stop_distance"));
  r = call(ch, "config_log", Value::map().set("n", 5));
  ASSERT_TRUE(r.ok()) << r.error;
  EXPECT_EQ(r.message.payload["transactions"].as_int(), 1);
  EXPECT_EQ(r.message.payload["txns"].as_array().size(), 1u);
  EXPECT_EQ(r.message.payload["path"], Value((dir_ / "h1" / "config.db").string()));
  r = call(ch, "config_bogus");
  EXPECT_NE(r.error.find("unknown request 'config_bogus'"), std::string::npos) << r.error;
}

TEST_F(ConfigServiceTest, ThreeDaemonsReplicateWritesFromEachAndWatchesFire) {
  auto* c = start(options("c", {}));
  auto* b = start(options("b", {c->address()}));
  auto* a = start(options("a", {b->address(), c->address()}));
  auto ca = connect(a->address()), cb = connect(b->address()), cc = connect(c->address());
  ASSERT_TRUE(ca && cb && cc);
  ASSERT_TRUE(call(cc, "config_watch", Value::map().set("prefix", "door")).ok());
  set(ca, "door.width", 0.9);
  set(cb, "robot.dof", 6);
  set(cc, "door.mass", 20);  // c has no peers of its own: it replicates with those that ask it
  EXPECT_TRUE(everywhere({ca, cb, cc}, "door.width", Value(0.9)));
  EXPECT_TRUE(everywhere({ca, cb, cc}, "robot.dof", Value(6)));
  EXPECT_TRUE(everywhere({ca, cb, cc}, "door.mass", Value(20)));
  EXPECT_EQ(content("a"), content("b"));
  EXPECT_EQ(content("a"), content("c"));
  // c's watch saw its own write and a's replicated one, not robot.dof.
  ASSERT_TRUE(loop_.run_until(
      [&] {
        int n = 0;
        for (const auto& e : events_)
          if (e.type == "config_changed") ++n;
        return n >= 2;
      },
      10s));
  std::set<std::string> seen;
  for (const auto& e : events_) {
    if (e.type != "config_changed") continue;
    seen.insert(e.payload["key"].as_string());
    EXPECT_EQ(e.payload["prefix"], Value("door"));
  }
  EXPECT_EQ(seen, (std::set<std::string>{"door.mass", "door.width"}));
  for (const auto& e : events_) {
    if (e.type == "config_changed" && e.payload["key"] == Value("door.width")) {
      EXPECT_EQ(e.payload["value"], Value(0.9));
      EXPECT_EQ(e.payload["origin"], Value(a->config()->store()->origin()));
    }
  }
}

TEST_F(ConfigServiceTest, AStoppedDaemonCatchesUpAndConcurrentWritesConflictTheSameWayEverywhere) {
  auto* b = start(options("b", {}));
  const std::string b_addr = b->address().str();
  auto* a = start(options("a", {b->address()}));
  auto ca = connect(a->address()), cb = connect(b->address());
  set(ca, "door.stop_distance", 0.5);
  ASSERT_TRUE(everywhere({ca, cb}, "door.stop_distance", Value(0.5)));
  // b goes away; both sides write, the same key included.
  daemons_.erase("b");
  loop_.run_for(20ms);
  set(ca, "door.stop_distance", 0.4);
  set(ca, "a.only", 1);
  loop_.run_for(20ms);
  {
    // b's side of the partition: written into its replica while its daemon is down (a is not told)
    dca::config::StoreOptions so;
    so.path = (dir_ / "b" / "config.db").string();
    so.host = "b";
    std::string e;
    auto store = dca::config::ConfigStore::open(so, &e);
    ASSERT_TRUE(store) << e;
    ASSERT_TRUE(store->set({{"door.stop_distance", Value(0.3)}}, nullptr, &e)) << e;  // later stamp: it wins
    ASSERT_TRUE(store->set({{"b.only", Value(2)}}, nullptr, &e)) << e;
  }
  auto* b2 = start(options("b", {}, b_addr));  // same state dir, same address
  ASSERT_EQ(b2->address().str(), b_addr);
  cb = connect(b2->address());
  EXPECT_TRUE(everywhere({ca, cb}, "door.stop_distance", Value(0.3)));
  EXPECT_TRUE(everywhere({ca, cb}, "a.only", Value(1)));
  EXPECT_TRUE(everywhere({ca, cb}, "b.only", Value(2)));
  EXPECT_EQ(content("a"), content("b"));
  for (const auto& ch : {ca, cb}) {
    auto r = call(ch, "config_log", Value::map().set("n", 10));
    ASSERT_TRUE(r.ok()) << r.error;
    const auto& cs = r.message.payload["conflicts"].as_array();
    ASSERT_EQ(cs.size(), 1u) << r.message.payload.str();
    EXPECT_EQ(cs[0]["key"], Value("door.stop_distance"));
    EXPECT_EQ(cs[0]["loser"]["value"], Value(0.4));
    EXPECT_EQ(cs[0]["winner"]["value"], Value(0.3));
  }
  auto st = call(ca, "config_status");
  ASSERT_TRUE(st.ok());
  ASSERT_EQ(st.message.payload["peers"].as_array().size(), 1u);
  EXPECT_GT(st.message.payload["peers"].as_array()[0]["syncs"].as_int(), 0);
}

TEST_F(ConfigServiceTest, ACatchUpLargerThanOneBatchArrivesWhole) {
  {
    // 5000 transactions written before a's daemon starts (synchronous=NORMAL: quicker to fill)
    fs::create_directories(dir_ / "a");
    dca::config::StoreOptions so;
    so.path = (dir_ / "a" / "config.db").string();
    so.host = "a";
    so.sync_full = false;
    std::string e;
    auto store = dca::config::ConfigStore::open(so, &e);
    ASSERT_TRUE(store) << e;
    for (int i = 0; i < 5000; ++i)
      ASSERT_TRUE(store->set({{"bulk.n" + std::to_string(i % 100), Value(i)}}, nullptr, &e)) << e;
  }
  auto* a = start(options("a", {}));
  auto o = options("b", {a->address()});
  auto* b = start(o);  // default batch 2000: 5000 transactions take 3 replies
  auto cb = connect(b->address());
  EXPECT_TRUE(everywhere({cb}, "bulk.n99", Value(4999)));
  EXPECT_EQ(b->config()->store()->transactions(), 5000u);
}

TEST_F(ConfigServiceTest, RefusesToStartOnACorruptDatabaseNamingTheFile) {
  fs::create_directories(dir_ / "h1");
  {
    std::ofstream f(dir_ / "h1" / "config.db", std::ios::binary);
    f << std::string(4096, 'x');
  }
  dca::Daemon d(loop_.io(), options("h1", {}));
  std::string error;
  EXPECT_FALSE(d.start(&error));
  EXPECT_NE(error.find("configuration database " + (dir_ / "h1" / "config.db").string() + " is not usable"),
            std::string::npos)
      << error;
}

TEST_F(ConfigServiceTest, OneDaemonPerStateDirectory) {
  start(options("h1", {}));
  auto o = options("h1", {});
  dca::Daemon second(loop_.io(), o);
  std::string error;
  EXPECT_FALSE(second.start(&error));
  EXPECT_NE(error.find("is in use by another daemon (pid " + std::to_string(::getpid()) + ")"), std::string::npos) << error;
  // A defaulted directory in use: the daemon runs, without a repository, and says why.
  o.state_dir_is_default = true;
  dca::Daemon third(loop_.io(), o);
  ASSERT_TRUE(third.start(&error)) << error;
  auto ch = connect(third.address());
  auto r = call(ch, "config_get", Value::map().set("key", "a.b"));
  EXPECT_NE(r.error.find("no configuration repository on host h1: the state directory"), std::string::npos) << r.error;
  // Without a state directory at all.
  o.state_dir.clear();
  dca::Daemon fourth(loop_.io(), o);
  ASSERT_TRUE(fourth.start(&error)) << error;
  auto ch4 = connect(fourth.address());
  r = call(ch4, "config_list");
  EXPECT_NE(r.error.find("no configuration repository on host h1 (its daemon runs without a state directory)"),
            std::string::npos)
      << r.error;
}

}  // namespace
