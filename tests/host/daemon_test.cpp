#include "host/daemon.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/write.hpp>
#include <algorithm>
#include <cstddef>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <regex>
#include <sstream>

#include "host/systemd.h"
#include "tests/support/channel_pair.h"
#include "tests/support/temp_dir.h"

extern char** environ;

namespace {

using namespace std::chrono_literals;
using namespace dca::test;  // Address, Channel, ..., kKey

bool process_exists(pid_t pid) { return std::filesystem::exists("/proc/" + std::to_string(pid)); }

// A client of one daemon: a channel, the events it received, and blocking helpers driven by the loop.
struct Client {
  dca::Loop& loop;
  Channel::Ptr ch;
  std::vector<Message> events;
  std::string closed;

  // A request whose answer comes later: `done` turns true when `got` holds it.
  struct Pending {
    Response got;
    bool done = false;
  };
  std::shared_ptr<Pending> send(Message m, std::chrono::milliseconds timeout = 10s) {
    auto p = std::make_shared<Pending>();
    ch->request(std::move(m), timeout, [p](Response got) {
      p->got = std::move(got);
      p->done = true;
    });
    return p;
  }
  // Spawns two sleeping shells, the second deaf to SIGTERM: their pids (fewer when a spawn failed).
  std::vector<pid_t> spawn_two_sleepers() {
    std::vector<pid_t> pids;
    for (const char* script : {"sleep 100", "trap '' TERM; sleep 100 & wait"}) {
      const auto r = call(Message{"spawn", 0, Value::map().set("argv", Value::Array{"/bin/sh", "-c", script})});
      EXPECT_TRUE(r.ok()) << r.error;
      if (!r.ok()) break;
      pids.push_back(static_cast<pid_t>(r.message.payload["pid"].as_int()));
    }
    return pids;
  }
  Response call(Message m, std::chrono::milliseconds timeout = 10s) {
    const auto p = send(std::move(m), timeout);
    EXPECT_TRUE(loop.run_until([&] { return p->done; }, timeout + 5s));
    return p->got;
  }
  const Message* wait_event(const std::string& type, std::chrono::milliseconds timeout = 20s) {
    const auto find = [&]() -> const Message* {
      for (const auto& e : events)
        if (e.type == type) return &e;
      return nullptr;
    };
    loop.run_until([&] { return find() != nullptr; }, timeout);
    return find();
  }
};

std::unique_ptr<Client> connect(dca::Loop& loop, const Address& to, std::string key = kKey,
                                std::string* error = nullptr) {
  auto c = std::make_unique<Client>(Client{loop, nullptr, {}, {}});
  bool done = false;
  std::string err;
  Channel::connect(loop.io(), to, ChannelOptions{std::move(key)}, [&](Channel::Ptr ch, const std::string& e) {
    c->ch = std::move(ch);
    err = e;
    done = true;
  });
  EXPECT_TRUE(loop.run_until([&] { return done; }, 20s));
  if (error != nullptr) *error = err;
  if (!c->ch) return nullptr;
  Client* raw = c.get();
  c->ch->on_message([raw](const Message& m) { raw->events.push_back(m); });
  c->ch->on_close([raw](const std::string& why) { raw->closed = why; });
  return c;
}

Message req(const std::string& type, Value payload = Value::map()) { return Message{type, 0, std::move(payload)}; }

class DaemonTest : public ::testing::Test {
 protected:
  std::unique_ptr<dca::Daemon> make(const std::string& host, std::vector<Address> peers = {}) {
    dca::DaemonOptions o;
    o.host = host;
    o.key = kKey;
    o.peers = std::move(peers);
    o.allow.allow("/bin/sh");
    o.allow.allow("/bin/sleep");
    o.stop_grace = 200ms;
    auto d = std::make_unique<dca::Daemon>(loop_.io(), o);
    std::string error;
    EXPECT_TRUE(d->start(&error)) << error;
    return d;
  }
  dca::Loop loop_;
};

TEST_F(DaemonTest, SpawnReportsExitCodeToTheRequester) {
  auto d = make("h1");
  auto c = connect(loop_, d->address());
  ASSERT_TRUE(c);
  const auto r = c->call(req("spawn", Value::map().set("argv", Value::Array{"/bin/sh", "-c", "exit 3"}).set("name", "three")));
  ASSERT_TRUE(r.ok()) << r.error;
  EXPECT_GT(r.message.payload["pid"].as_int(), 0);
  const Message* ev = c->wait_event("exit");
  ASSERT_NE(ev, nullptr);
  EXPECT_EQ(ev->payload["code"].as_int(-1), 3);
  EXPECT_EQ(ev->payload["child"], r.message.payload["child"]);
  EXPECT_EQ(ev->payload["name"].as_string(), "three");
  EXPECT_EQ(ev->payload["host"].as_string(), "h1");
  EXPECT_TRUE(ev->payload["signal"].is_nil());
}

// A child that fails before it is ready says why (`failed`, host/node.h): its exit event carries the reason.
TEST_F(DaemonTest, AFailedChildsReasonGoesWithItsExit) {
  auto d = make("h1");
  auto c = connect(loop_, d->address());
  ASSERT_TRUE(c);
  const auto r = c->call(req("spawn", Value::map().set("argv", Value::Array{"/bin/sleep", "100"}).set("name", "n")));
  ASSERT_TRUE(r.ok()) << r.error;
  const auto pid = r.message.payload["pid"].as_int();
  const auto told = c->call(req("failed", Value::map().set("pid", pid).set("reason", "parameter 'k' must be positive")));
  EXPECT_TRUE(told.ok()) << told.error;
  const auto stranger = c->call(req("failed", Value::map().set("pid", 1).set("reason", "x")));
  EXPECT_EQ(stranger.error, "failed: no child with pid 1 on host h1");
  ASSERT_TRUE(c->call(req("kill", Value::map().set("child", r.message.payload["child"]))).ok());
  const Message* ev = c->wait_event("exit");
  ASSERT_NE(ev, nullptr);
  EXPECT_EQ(ev->payload["reason"].as_string(), "parameter 'k' must be positive");
  EXPECT_EQ(ev->payload["signal"].as_string(), "SIGTERM");
}

// A child's stderr lines go to its requester as output events, before its exit; past the budget they are
// left out and counted, the count also before the exit.
TEST_F(DaemonTest, AChildsStderrLinesGoToItsRequesterCountedPastTheBudget) {
  auto d = make("h1");
  auto c = connect(loop_, d->address());
  ASSERT_TRUE(c);
  const std::string flood = "i=0; while [ $i -lt 3000 ]; do echo \"line $i\" >&2; i=$((i+1)); done";
  for (const std::string& script : {std::string("echo one >&2; echo two >&2"), flood}) {
    c->events.clear();
    const auto r = c->call(req("spawn", Value::map().set("argv", Value::Array{"/bin/sh", "-c", script}).set("name", "s")));
    ASSERT_TRUE(r.ok()) << r.error;
    ASSERT_NE(c->wait_event("exit"), nullptr);
    std::vector<std::string> lines;
    std::int64_t dropped = 0;
    for (const auto& e : c->events) {
      if (e.type == "exit") break;
      ASSERT_EQ(e.type, "output");
      EXPECT_EQ(e.payload["name"].as_string(), "s");
      EXPECT_EQ(e.payload["host"].as_string(), "h1");
      if (e.payload["line"].is_string()) lines.push_back(e.payload["line"].as_string());
      dropped += e.payload["dropped"].as_int();
    }
    if (script != flood) {
      EXPECT_EQ(lines, (std::vector<std::string>{"one", "two"}));
      EXPECT_EQ(dropped, 0);
      continue;
    }
    EXPECT_GE(lines.size(), static_cast<std::size_t>(dca::kOutputBurst));
    EXPECT_EQ(lines.front(), "line 0");
    EXPECT_EQ(static_cast<std::int64_t>(lines.size()) + dropped, 3000);
  }
}

TEST_F(DaemonTest, SpawnReportsSignalAndKillsOnRequest) {
  auto d = make("h1");
  auto c = connect(loop_, d->address());
  ASSERT_TRUE(c);
  auto r = c->call(req("spawn", Value::map().set("argv", Value::Array{"/bin/sh", "-c", "ulimit -c 0; kill -SEGV $$"})));
  ASSERT_TRUE(r.ok()) << r.error;
  const Message* segv = c->wait_event("exit");
  ASSERT_NE(segv, nullptr);
  EXPECT_EQ(segv->payload["signal"].as_string(), "SIGSEGV");
  c->events.clear();
  r = c->call(req("spawn", Value::map().set("argv", Value::Array{"/bin/sleep", "100"})));
  ASSERT_TRUE(r.ok()) << r.error;
  const auto kill = c->call(req("kill", Value::map().set("child", r.message.payload["child"]).set("signal", "SIGKILL")));
  EXPECT_TRUE(kill.ok()) << kill.error;
  const Message* killed = c->wait_event("exit");
  ASSERT_NE(killed, nullptr);
  EXPECT_EQ(killed->payload["signal"].as_string(), "SIGKILL");
  const auto again = c->call(req("kill", Value::map().set("child", r.message.payload["child"])));
  EXPECT_NE(again.error.find("no running child"), std::string::npos) << again.error;
  // kill also works as an event (no reply).
  c->events.clear();
  r = c->call(req("spawn", Value::map().set("argv", Value::Array{"/bin/sleep", "100"})));
  ASSERT_TRUE(r.ok()) << r.error;
  c->ch->send(Message{"kill", 0, Value::map().set("child", r.message.payload["child"]).set("signal", "TERM")});
  const Message* termed = c->wait_event("exit");
  ASSERT_NE(termed, nullptr);
  EXPECT_EQ(termed->payload["signal"].as_string(), "SIGTERM");
}

// A shared spawn (a shared node, dca run --placement): the second requester joins the running child, both hear
// its exit; once every holder has released it (or closed its channel), it is ended and a new one starts.
TEST_F(DaemonTest, SharedSpawnJoinsTheRunningChildAndEndsItWhenNobodyHoldsIt) {
  auto d = make("h1");
  auto a = connect(loop_, d->address());
  auto b = connect(loop_, d->address());
  ASSERT_TRUE(a && b);
  const auto shared = [](const char* name) {
    return req("spawn", Value::map().set("argv", Value::Array{"/bin/sleep", "100"}).set("name", name).set("shared", true));
  };
  auto ra = a->call(shared("leaves@h1"));
  ASSERT_TRUE(ra.ok()) << ra.error;
  EXPECT_FALSE(ra.message.payload["joined"].as_bool());
  auto rb = b->call(shared("leaves@h1"));
  ASSERT_TRUE(rb.ok()) << rb.error;
  EXPECT_TRUE(rb.message.payload["joined"].as_bool());
  EXPECT_EQ(rb.message.payload["child"], ra.message.payload["child"]);
  EXPECT_EQ(rb.message.payload["pid"], ra.message.payload["pid"]);
  EXPECT_NE(a->call(shared("other")).message.payload["child"], ra.message.payload["child"]);  // per name
  // a crash is heard by every holder
  ASSERT_TRUE(a->call(req("kill", Value::map().set("child", ra.message.payload["child"]).set("signal", "SEGV"))).ok());
  for (auto* c : {a.get(), b.get()}) {
    const Message* ev = c->wait_event("exit");
    ASSERT_NE(ev, nullptr);
    EXPECT_EQ(ev->payload["signal"].as_string(), "SIGSEGV");
    EXPECT_EQ(ev->payload["child"], ra.message.payload["child"]);
  }
  // after its end a shared spawn starts anew; released by both, it is ended (SIGTERM)
  a->events.clear();
  ra = a->call(shared("leaves@h1"));
  EXPECT_FALSE(ra.message.payload["joined"].as_bool());
  rb = b->call(shared("leaves@h1"));
  EXPECT_TRUE(rb.message.payload["joined"].as_bool());
  ASSERT_TRUE(a->call(req("release", Value::map().set("child", ra.message.payload["child"]))).ok());
  b->ch->close("gone");  // a closed channel releases too
  const auto id = static_cast<dca::Executer::ChildId>(ra.message.payload["child"].as_int());
  const auto running = [&] {
    for (const auto& [child, pid] : d->executer().children())
      if (child == id) return true;
    return false;
  };
  ASSERT_TRUE(loop_.run_until([&] { return !running(); }, 20s));
  EXPECT_EQ(a->wait_event("exit", 0ms), nullptr);  // a released it: no event for a
  auto rc = a->call(shared("leaves@h1"));
  EXPECT_FALSE(rc.message.payload["joined"].as_bool());  // nobody held the old one: a new child
  EXPECT_NE(rc.message.payload["child"], ra.message.payload["child"]);
  EXPECT_NE(a->call(req("release", Value::map().set("child", 999))).error.find("no shared child 999"), std::string::npos);
}

// Fencing (host/fence.h): a child spawned with `fence` is ended once its requester's channel has been silent that
// long (SIGTERM, then SIGKILL to one deaf to it), its exit saying why; pings renew the lease; a closed channel
// fences at once; a bad fence is refused.
TEST_F(DaemonTest, AChildIsFencedWhenItsRequesterIsSilentOrGone) {
  auto d = make("h1");
  auto c = connect(loop_, d->address());
  ASSERT_TRUE(c);
  const auto fenced = [](const char* script, double fence, double kill_after) {
    return req("spawn", Value::map()
                            .set("argv", Value::Array{"/bin/sh", "-c", script})
                            .set("name", "main.leaf")
                            .set("fence", fence)
                            .set("kill_after", kill_after));
  };
  ASSERT_TRUE(c->call(fenced("sleep 100", 0.3, 5)).ok());
  const Message* ev = c->wait_event("exit");
  ASSERT_NE(ev, nullptr);
  EXPECT_EQ(ev->payload["signal"].as_string(), "SIGTERM");
  EXPECT_NE(ev->payload["reason"].as_string().find("fenced on host h1: its supervisor ("), std::string::npos)
      << ev->payload["reason"].str();
  EXPECT_NE(ev->payload["reason"].as_string().find("was silent for"), std::string::npos);
  c->events.clear();
  ASSERT_TRUE(c->call(fenced("trap '' TERM; sleep 100 & wait", 0.2, 0.2)).ok());
  ev = c->wait_event("exit");
  ASSERT_NE(ev, nullptr);
  EXPECT_EQ(ev->payload["signal"].as_string(), "SIGKILL");  // deaf to SIGTERM

  // renewed by pings (every 0.1 s against a fence of 1 s), then the channel closes: fenced at once
  c->events.clear();
  auto r = c->call(fenced("sleep 100", 1, 5));
  ASSERT_TRUE(r.ok()) << r.error;
  const auto pid = static_cast<pid_t>(r.message.payload["pid"].as_int());
  for (int i = 0; i < 15; ++i) {
    ASSERT_TRUE(c->call(req("ping")).ok());
    loop_.run_for(100ms);
  }
  EXPECT_TRUE(process_exists(pid)) << "1.5 s of pings kept it";
  c->ch->close("gone");
  EXPECT_TRUE(loop_.run_until([&] { return !process_exists(pid); }, 20s));

  auto b = connect(loop_, d->address());
  ASSERT_TRUE(b);
  EXPECT_NE(b->call(fenced("sleep 1", -1, 1)).error.find("fence and kill_after must be seconds above 0"),
            std::string::npos);

  // a shared child two requesters hold is fenced with the last lease: a silent one alone does not end it
  auto a = connect(loop_, d->address());
  ASSERT_TRUE(a);
  const auto shared = [](double fence) {
    return req("spawn", Value::map()
                            .set("argv", Value::Array{"/bin/sleep", "100"})
                            .set("name", "leaves@h1")
                            .set("shared", true)
                            .set("fence", fence));
  };
  r = a->call(shared(0.3));
  ASSERT_TRUE(r.ok()) << r.error;
  ASSERT_TRUE(b->call(shared(5)).ok());
  const auto node = static_cast<pid_t>(r.message.payload["pid"].as_int());
  loop_.run_for(600ms);  // a's lease lapsed
  EXPECT_TRUE(process_exists(node)) << "b still holds it";
  b->ch->close("gone");
  EXPECT_TRUE(loop_.run_until([&] { return !process_exists(node); }, 20s));
}

TEST_F(DaemonTest, RefusesProgramsNotOnTheAllowList) {
  auto d = make("h1");
  auto c = connect(loop_, d->address());
  ASSERT_TRUE(c);
  const auto r = c->call(req("spawn", Value::map().set("argv", Value::Array{"/bin/rm", "-rf", "/tmp/x"})));
  EXPECT_FALSE(r.ok());
  EXPECT_NE(r.error.find("not allowed"), std::string::npos) << r.error;
  EXPECT_NE(r.error.find("host h1"), std::string::npos) << r.error;
  EXPECT_EQ(d->executer().running(), 0u);
}

TEST_F(DaemonTest, RegisterLookupUnregister) {
  auto d = make("h1");
  auto a = connect(loop_, d->address());
  auto b = connect(loop_, d->address());
  ASSERT_TRUE(a && b);
  auto r = a->call(req("register", Value::map().set("name", "/sys/arm").set("endpoints", Value::map().set("control", "127.0.0.1:1"))));
  ASSERT_TRUE(r.ok()) << r.error;
  r = b->call(req("lookup", Value::map().set("name", "/sys/arm")));
  ASSERT_TRUE(r.ok()) << r.error;
  EXPECT_EQ(r.message.payload["endpoints"]["control"].as_string(), "127.0.0.1:1");
  EXPECT_EQ(r.message.payload["host"].as_string(), "h1");
  r = b->call(req("register", Value::map().set("name", "/sys/arm")));
  EXPECT_NE(r.error.find("already registered"), std::string::npos) << r.error;
  r = b->call(req("unregister", Value::map().set("name", "/sys/arm")));
  EXPECT_NE(r.error.find("another process"), std::string::npos) << r.error;
  r = a->call(req("unregister", Value::map().set("name", "/sys/arm")));
  EXPECT_TRUE(r.ok()) << r.error;
  r = b->call(req("lookup", Value::map().set("name", "/sys/arm")));
  EXPECT_EQ(r.error, "no process named '/sys/arm' on host h1");
}

TEST_F(DaemonTest, NamesGoAwayWhenTheirChannelCloses) {
  auto d = make("h1");
  auto a = connect(loop_, d->address());
  auto b = connect(loop_, d->address());
  ASSERT_TRUE(a && b);
  ASSERT_TRUE(a->call(req("register", Value::map().set("name", "n"))).ok());
  a->ch->close();
  ASSERT_TRUE(loop_.run_until([&] { return d->names().table().size() == 0; }, 10s));
  EXPECT_FALSE(b->call(req("lookup", Value::map().set("name", "n"))).ok());
}

TEST_F(DaemonTest, LookupWaitsForANameRegisteredLater) {
  auto d = make("h1");
  auto a = connect(loop_, d->address());
  auto b = connect(loop_, d->address());
  ASSERT_TRUE(a && b);
  const auto got = b->send(req("lookup", Value::map().set("name", "late").set("wait_ms", 10000)), 20s);
  ASSERT_TRUE(loop_.run_until([&] { return d->names().table().waiting() == 1; }, 10s));
  EXPECT_FALSE(got->done);
  ASSERT_TRUE(a->call(req("register", Value::map().set("name", "late").set("endpoints", Value::map().set("pid", 5)))).ok());
  ASSERT_TRUE(loop_.run_until([&] { return got->done; }, 10s));
  EXPECT_TRUE(got->got.ok()) << got->got.error;
  EXPECT_EQ(got->got.message.payload["endpoints"]["pid"].as_int(), 5);
  // A wait that ends without the name is an error naming the wait.
  const auto r = b->call(req("lookup", Value::map().set("name", "never").set("wait_ms", 30)));
  EXPECT_EQ(r.error, "no process named 'never' on host h1 within 30 ms");
  EXPECT_EQ(d->names().table().waiting(), 0u);
}

TEST_F(DaemonTest, LookupIsAnsweredByPeers) {
  auto c_daemon = make("hc");
  auto b_daemon = make("hb");
  auto a_daemon = make("ha", {b_daemon->address(), c_daemon->address()});
  auto on_c = connect(loop_, c_daemon->address());
  auto on_a = connect(loop_, a_daemon->address());
  ASSERT_TRUE(on_c && on_a);
  ASSERT_TRUE(on_c->call(req("register", Value::map().set("name", "/far").set("endpoints", Value::map().set("pid", 9)))).ok());
  auto r = on_a->call(req("lookup", Value::map().set("name", "/far")));
  ASSERT_TRUE(r.ok()) << r.error;
  EXPECT_EQ(r.message.payload["host"].as_string(), "hc");
  EXPECT_EQ(r.message.payload["endpoints"]["pid"].as_int(), 9);
  r = on_a->call(req("lookup", Value::map().set("name", "/nowhere")));
  EXPECT_EQ(r.error, "no process named '/nowhere' on host ha or its 2 peers");
  // Waiting look-ups also wait at the peers.
  const auto later = on_a->send(req("lookup", Value::map().set("name", "/later").set("wait_ms", 10000)), 20s);
  ASSERT_TRUE(loop_.run_until([&] { return c_daemon->names().table().waiting() == 1; }, 10s));
  ASSERT_TRUE(on_c->call(req("register", Value::map().set("name", "/later"))).ok());
  ASSERT_TRUE(loop_.run_until([&] { return later->done; }, 10s));
  EXPECT_TRUE(later->got.ok()) << later->got.error;
  EXPECT_EQ(later->got.message.payload["host"].as_string(), "hc");
}

TEST_F(DaemonTest, UnreachablePeerIsNamedInTheError) {
  boost::asio::ip::tcp::acceptor probe(loop_.io(), {boost::asio::ip::make_address("127.0.0.1"), 0});
  const auto dead = *Address::parse("127.0.0.1:" + std::to_string(probe.local_endpoint().port()));
  probe.close();
  auto a_daemon = make("ha", {dead});
  auto on_a = connect(loop_, a_daemon->address());
  ASSERT_TRUE(on_a);
  const auto r = on_a->call(req("lookup", Value::map().set("name", "x")));
  EXPECT_NE(r.error.find(dead.str() + ": unreachable"), std::string::npos) << r.error;
}

TEST_F(DaemonTest, StopLeavesNoChildAndClosesChannels) {
  auto d = make("h1");
  auto c = connect(loop_, d->address());
  ASSERT_TRUE(c);
  const std::vector<pid_t> pids = c->spawn_two_sleepers();
  ASSERT_EQ(pids.size(), 2u);
  d->stop();
  for (pid_t p : pids) EXPECT_FALSE(process_exists(p)) << "child " << p << " is still in /proc";
  ASSERT_TRUE(loop_.run_until([&] { return !c->closed.empty(); }, 10s));
  EXPECT_NE(c->closed.find("the daemon on host h1 stopped"), std::string::npos) << c->closed;
}

TEST_F(DaemonTest, UnknownRequestIsAnError) {
  auto d = make("h1");
  auto c = connect(loop_, d->address());
  ASSERT_TRUE(c);
  const auto r = c->call(req("frobnicate"));
  EXPECT_EQ(r.error, "unknown request 'frobnicate' (daemon on host h1)");
  const auto p = c->call(req("ping"));
  EXPECT_EQ(p.message.payload["host"].as_string(), "h1");
}

// ------------------------------------------------------------------------ real `dca daemon` processes

// A `dca daemon` child process; its listen address is read from the line it prints when ready.
class DaemonProcess {
 public:
  DaemonProcess(const std::vector<std::string>& args, const std::string& key_file, const std::string& err_file = "") {
    int out[2];
    EXPECT_EQ(::pipe2(out, O_CLOEXEC), 0);
    std::vector<std::string> argv = {DCA_TEST_EXE, "daemon", "--key", key_file};
    argv.insert(argv.end(), args.begin(), args.end());
    std::vector<char*> cargv;
    for (auto& a : argv) cargv.push_back(a.data());
    cargv.push_back(nullptr);
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_adddup2(&fa, out[1], 1);
    if (!err_file.empty()) posix_spawn_file_actions_addopen(&fa, 2, err_file.c_str(), O_WRONLY | O_APPEND, 0);
    EXPECT_EQ(::posix_spawn(&pid_, DCA_TEST_EXE, &fa, nullptr, cargv.data(), environ), 0);
    posix_spawn_file_actions_destroy(&fa);
    ::close(out[1]);
    // Read the ready line (bounded).
    std::string line;
    for (int waited = 0; line.find('\n') == std::string::npos && waited < 20000;) {
      pollfd p{out[0], POLLIN, 0};
      if (::poll(&p, 1, 100) <= 0) {
        waited += 100;
        continue;
      }
      char buf[256];
      const ssize_t n = ::read(out[0], buf, sizeof buf);
      if (n <= 0) break;
      line.append(buf, static_cast<std::size_t>(n));
    }
    ::close(out[0]);
    line_ = line;
    const auto at = line.find(" listening on ");
    EXPECT_NE(at, std::string::npos) << "daemon said: " << line;
    if (at != std::string::npos) address_ = *Address::parse(line.substr(at + 14, line.find('\n') - at - 14));
  }
  ~DaemonProcess() { stop(); }
  /// SIGTERM, then waits for it; returns its exit status.
  int stop() {
    if (pid_ <= 0) return status_;
    ::kill(pid_, SIGTERM);
    ::waitpid(pid_, &status_, 0);
    pid_ = 0;
    return status_;
  }
  const Address& address() const { return address_; }
  const std::string& line() const { return line_; }

 private:
  pid_t pid_ = 0;
  int status_ = 0;
  Address address_;
  std::string line_;
};

class DaemonProcessTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_FALSE(dir_.empty());
    key_file_ = dir_ + "/key";
    std::string error;
    auto key = dca::auth::load_or_create_key(key_file_, &error);
    ASSERT_TRUE(key) << error;
    key_ = *key;
  }
  // A free loopback port (bound then released, so a daemon started next can use it as a peer address).
  std::string free_port_address() {
    boost::asio::ip::tcp::acceptor a(loop_.io(), {boost::asio::ip::make_address("127.0.0.1"), 0});
    return "127.0.0.1:" + std::to_string(a.local_endpoint().port());
  }
  dca::Loop loop_;
  dca::test::TempDir tmp_{"daemon_test"};
  std::string dir_ = tmp_.path(), key_file_;
  dca::auth::Key key_;
};

TEST_F(DaemonProcessTest, PrintsItsAddressAndRefusesAKeyFileReadableByOthers) {
  DaemonProcess d({"--host", "h1", "--listen", "127.0.0.1:0"}, key_file_);
  EXPECT_EQ(d.line().rfind("dca daemon: host h1 listening on 127.0.0.1:", 0), 0u) << d.line();
  EXPECT_NE(d.address().port, 0);
  EXPECT_EQ(d.stop(), 0);
  ::chmod(key_file_.c_str(), 0640);
  const std::string cmd = std::string(DCA_TEST_EXE) + " daemon --key " + key_file_ + " 2>&1";
  FILE* p = ::popen(cmd.c_str(), "r");
  ASSERT_NE(p, nullptr);
  char buf[512] = {};
  const std::size_t n = std::fread(buf, 1, sizeof buf - 1, p);
  const int status = ::pclose(p);
  EXPECT_NE(WEXITSTATUS(status), 0);
  EXPECT_NE(std::string(buf, n).find("key file " + key_file_ + " has mode 0640; it must be 0600"), std::string::npos)
      << std::string(buf, n);
}

TEST_F(DaemonProcessTest, SigtermKillsAndReapsEveryChild) {
  DaemonProcess d({"--host", "h1", "--allow", "/bin/sh", "--grace", "100"}, key_file_);
  auto c = connect(loop_, d.address(), key_);
  ASSERT_TRUE(c);
  const std::vector<pid_t> pids = c->spawn_two_sleepers();
  ASSERT_EQ(pids.size(), 2u);
  for (pid_t p : pids) EXPECT_TRUE(process_exists(p));
  const int status = d.stop();
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << status;
  for (pid_t p : pids) EXPECT_FALSE(process_exists(p)) << "child " << p << " outlived its daemon";
  ASSERT_TRUE(loop_.run_until([&] { return !c->closed.empty(); }, 10s));
}

// Three daemons on loopback acting as three hosts, configured as peers.
TEST_F(DaemonProcessTest, ThreeDaemonsAsThreeHosts) {
  const std::string a_addr = free_port_address(), b_addr = free_port_address(), c_addr = free_port_address();
  DaemonProcess a({"--host", "A", "--listen", a_addr, "--peer", b_addr, "--peer", c_addr}, key_file_);
  DaemonProcess b({"--host", "B", "--listen", b_addr, "--peer", a_addr, "--peer", c_addr, "--allow", "/bin/sh"},
                  key_file_);
  DaemonProcess c({"--host", "C", "--listen", c_addr, "--peer", a_addr, "--peer", b_addr}, key_file_);
  ASSERT_EQ(a.address().str(), a_addr);

  // A process on C registers a name; a client on A finds it without knowing its host.
  auto on_c = connect(loop_, c.address(), key_);
  auto on_a = connect(loop_, a.address(), key_);
  ASSERT_TRUE(on_c && on_a);
  ASSERT_TRUE(on_c->call(req("register", Value::map().set("name", "/door/arm").set("endpoints", Value::map().set("control", "x")))).ok());
  auto r = on_a->call(req("lookup", Value::map().set("name", "/door/arm")));
  ASSERT_TRUE(r.ok()) << r.error;
  EXPECT_EQ(r.message.payload["host"].as_string(), "C");

  // The client on A has B's daemon spawn a child, which dies by SIGSEGV: the exit event reaches A's client.
  auto to_b = connect(loop_, b.address(), key_);
  ASSERT_TRUE(to_b);
  r = to_b->call(req("spawn", Value::map().set("argv", Value::Array{"/bin/sh", "-c", "ulimit -c 0; kill -SEGV $$"})));
  ASSERT_TRUE(r.ok()) << r.error;
  EXPECT_EQ(r.message.payload["host"].as_string(), "B");
  const Message* ev = to_b->wait_event("exit");
  ASSERT_NE(ev, nullptr);
  EXPECT_EQ(ev->payload["signal"].as_string(), "SIGSEGV");
  EXPECT_EQ(ev->payload["host"].as_string(), "B");
  // B refuses programs that are not on its allow-list.
  r = to_b->call(req("spawn", Value::map().set("argv", Value::Array{"/bin/sleep", "1"})));
  EXPECT_NE(r.error.find("not allowed"), std::string::npos) << r.error;

  // A wrong key is refused, with a reason.
  std::string error;
  auto intruder = connect(loop_, a.address(), "the wrong key, 32 bytes long....", &error);
  EXPECT_FALSE(intruder);
  EXPECT_NE(error.find("key check"), std::string::npos) << error;

  // A malformed frame closes only its own connection: the other client of A carries on.
  auto victim = connect(loop_, a.address(), key_);
  ASSERT_TRUE(victim);
  const std::string garbage("\x00\x00\x00\x02\x93\xc1", 6);
  boost::asio::write(victim->ch->socket(), boost::asio::buffer(garbage));
  ASSERT_TRUE(loop_.run_until([&] { return !victim->closed.empty(); }, 10s));
  EXPECT_NE(victim->closed.find("malformed frame"), std::string::npos) << victim->closed;
  r = on_a->call(req("lookup", Value::map().set("name", "/door/arm")));
  EXPECT_TRUE(r.ok()) << r.error;

  // When C stops, its names go with it.
  EXPECT_EQ(c.stop(), 0);
  r = on_a->call(req("lookup", Value::map().set("name", "/door/arm")));
  EXPECT_FALSE(r.ok());
}

// ------------------------------------------------------------------------ under systemd (docs/deploy.md)

// A service manager's end of sd_notify: an abstract Unix datagram socket the test owns, and what came on it.
class NotifySocket {
 public:
  NotifySocket() : name_("@dca_daemon_test_notify_" + std::to_string(::getpid())) {
    fd_ = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    std::memcpy(addr.sun_path + 1, name_.data() + 1, name_.size() - 1);
    const auto len = static_cast<socklen_t>(offsetof(sockaddr_un, sun_path) + name_.size());
    EXPECT_EQ(::bind(fd_, reinterpret_cast<sockaddr*>(&addr), len), 0) << std::strerror(errno);
  }
  ~NotifySocket() { ::close(fd_); }
  const std::string& name() const { return name_; }
  /// The next datagram that starts with `prefix` (others are kept in seen()); "" after 20 s without one.
  std::string wait_for(const std::string& prefix) {
    for (int waited = 0; waited < 20000;) {
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, 100) <= 0) {
        waited += 100;
        continue;
      }
      char buf[4096];
      const ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
      if (n <= 0) continue;
      seen_.emplace_back(buf, static_cast<std::size_t>(n));
      if (seen_.back().rfind(prefix, 0) == 0) return seen_.back();
    }
    return "";
  }
  const std::vector<std::string>& seen() const { return seen_; }

 private:
  std::string name_;
  int fd_ = -1;
  std::vector<std::string> seen_;
};

// Sets environment variables for the processes a test starts, and unsets them when it ends.
struct ScopedEnv {
  explicit ScopedEnv(std::vector<std::pair<std::string, std::string>> vars) : vars_(std::move(vars)) {
    for (const auto& [k, v] : vars_) ::setenv(k.c_str(), v.c_str(), 1);
  }
  ~ScopedEnv() {
    for (const auto& [k, v] : vars_) ::unsetenv(k.c_str());
  }
  std::vector<std::pair<std::string, std::string>> vars_;
};

// Type=notify: READY=1 once it serves (a client is served right after), WATCHDOG=1 from its loop at half of
// WATCHDOG_USEC, STOPPING=1 at SIGTERM; the children it spawns inherit none of the service manager's variables.
TEST_F(DaemonProcessTest, UnderSystemdItNotifiesReadyWatchdogAndStopping) {
  NotifySocket manager;
  std::optional<DaemonProcess> d;
  {
    ScopedEnv env({{"NOTIFY_SOCKET", manager.name()}, {"WATCHDOG_USEC", "100000"}});
    d.emplace(std::vector<std::string>{"--host", "h1", "--allow", "/bin/sh", "--state-dir", "none"}, key_file_);
  }
  const std::string ready = manager.wait_for("READY=1");
  EXPECT_EQ(ready, "READY=1\nSTATUS=host h1 listening on " + d->address().str());
  auto c = connect(loop_, d->address(), key_);
  ASSERT_TRUE(c);
  EXPECT_TRUE(c->call(req("ping")).ok());
  EXPECT_EQ(manager.wait_for("WATCHDOG=1"), "WATCHDOG=1");
  EXPECT_EQ(manager.wait_for("WATCHDOG=1"), "WATCHDOG=1");
  const char* script = "echo \"[${NOTIFY_SOCKET-}${WATCHDOG_USEC-}]\" >&2";
  auto r = c->call(req("spawn", Value::map().set("argv", Value::Array{"/bin/sh", "-c", script})));
  ASSERT_TRUE(r.ok()) << r.error;
  const Message* line = c->wait_event("output");
  ASSERT_NE(line, nullptr);
  EXPECT_EQ(line->payload["line"].as_string(), "[]");
  ASSERT_NE(c->wait_event("exit"), nullptr);  // so that it has no child left to stop
  EXPECT_EQ(d->stop(), 0);
  EXPECT_EQ(manager.wait_for("STOPPING=1"), "STOPPING=1\nSTATUS=host h1 stopping (SIGTERM): 0 children to stop");
  EXPECT_EQ(manager.seen().front(), ready) << "READY=1 came first";
}

// A NOTIFY_SOCKET nobody listens on is an error; without one, nothing is sent. The watchdog is this process's only
// when WATCHDOG_PID is unset or names it.
TEST(SystemdNotifier, WithoutAManagerNothingIsSent) {
  dca::systemd::Notifier none;
  EXPECT_FALSE(none.enabled());
  EXPECT_FALSE(none.notify("READY=1"));
  ::setenv("NOTIFY_SOCKET", "@dca_daemon_test_nobody_listens", 1);
  ::setenv("WATCHDOG_USEC", "5000000", 1);
  ::setenv("WATCHDOG_PID", "1", 1);  // another process's watchdog: not ours to feed
  dca::systemd::Notifier lost;
  EXPECT_EQ(std::getenv("NOTIFY_SOCKET"), nullptr);
  EXPECT_EQ(std::getenv("WATCHDOG_USEC"), nullptr);
  EXPECT_TRUE(lost.enabled());
  EXPECT_EQ(lost.watchdog_period().count(), 0);
  std::string error;
  EXPECT_FALSE(lost.notify("READY=1", &error));
  EXPECT_NE(error.find("sd_notify to @dca_daemon_test_nobody_listens: "), std::string::npos) << error;
  ::setenv("NOTIFY_SOCKET", "@dca_daemon_test_nobody_listens", 1);
  ::setenv("WATCHDOG_USEC", "5000000", 1);
  ::setenv("WATCHDOG_PID", std::to_string(::getpid()).c_str(), 1);  // ours: fed at half of it
  dca::systemd::Notifier ours;
  EXPECT_EQ(ours.watchdog_period(), std::chrono::seconds(5));
}

// Under journald (JOURNAL_STREAM names its stderr) every line of the daemon's log starts with its syslog priority,
// its children's lines too, and none carries a time stamp; with another stderr, no prefix.
TEST_F(DaemonProcessTest, UnderJournaldItsLinesCarryPriorities) {
  const std::string log = dir_ + "/journal";
  std::ofstream(log).close();
  struct stat st {};
  ASSERT_EQ(::stat(log.c_str(), &st), 0);
  std::optional<DaemonProcess> d;
  {
    ScopedEnv env({{"JOURNAL_STREAM", std::to_string(st.st_dev) + ":" + std::to_string(st.st_ino)}});
    d.emplace(std::vector<std::string>{"--host", "h1", "--allow", "/bin/sh", "--state-dir", "none"}, key_file_, log);
  }
  auto c = connect(loop_, d->address(), key_);
  ASSERT_TRUE(c);
  auto r = c->call(req("spawn", Value::map().set("argv", Value::Array{"/bin/sh", "-c", "echo from the child >&2"})));
  ASSERT_TRUE(r.ok()) << r.error;
  ASSERT_NE(c->wait_event("exit"), nullptr);
  EXPECT_FALSE(connect(loop_, d->address(), "the wrong key, 32 bytes long...."));
  EXPECT_EQ(d->stop(), 0);
  std::ifstream in(log);
  std::vector<std::string> lines;
  for (std::string l; std::getline(in, l);) lines.push_back(l);
  ASSERT_GE(lines.size(), 4u);
  const std::regex prefixed("^<[3-7]>dca daemon|^<6>from the child$"), stamp("[0-9]{2}:[0-9]{2}:[0-9]{2}");
  for (const auto& l : lines) {
    EXPECT_TRUE(std::regex_search(l, prefixed)) << l;
    EXPECT_FALSE(std::regex_search(l, stamp)) << l;
  }
  const auto has = [&](const std::string& text) {
    return std::find(lines.begin(), lines.end(), text) != lines.end();
  };
  EXPECT_TRUE(has("<6>from the child"));
  EXPECT_TRUE(has("<5>dca daemon: host h1 stopping (SIGTERM): 0 children to stop"));
  EXPECT_TRUE(std::any_of(lines.begin(), lines.end(), [](const std::string& l) { return l.rfind("<4>", 0) == 0; }))
      << "the refused connection is a warning";

  // Another stderr than the journal's: plain lines.
  const std::string plain = dir_ + "/plain";
  std::ofstream(plain).close();
  {
    ScopedEnv env({{"JOURNAL_STREAM", std::to_string(st.st_dev) + ":" + std::to_string(st.st_ino)}});
    d.emplace(std::vector<std::string>{"--host", "h2", "--state-dir", "none"}, key_file_, plain);
  }
  EXPECT_EQ(d->stop(), 0);
  std::ifstream in2(plain);
  for (std::string l; std::getline(in2, l);) EXPECT_EQ(l.rfind("dca daemon", 0), 0u) << l;
}

}  // namespace
