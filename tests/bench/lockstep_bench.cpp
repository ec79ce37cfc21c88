// Lock-step simulated time across processes (BENCHMARKS.md format): how fast the world runs when N real node
// processes (`dca-node --clock sim`, Counter controllers) are advanced by it every tick, beside the raw world
// (World::step in a loop, no nodes, no sockets) in the same run, alternated A B A B.
//   RESULT bench=lockstep_rtf variant=<N>nodes_<P>ms ... rtf=<simulated s per wall s> per_tick_us=<wall per tick>
//   RESULT bench=raw_world_rtf variant=step_1ms ... rtf=...
// The latency fields are the wall time per simulated millisecond (one physics step), one sample per run.
// Usage: bench_lockstep [SIM_SECONDS]   (default 2)
#pragma GCC diagnostic ignored "-Wnull-dereference"
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"

#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "host/auth.h"
#include "host/channel.h"
#include "host/daemon.h"
#include "host/loop.h"
#include "host/node.h"
#include "sim/world.h"
#include "sim/world_node.h"

using Clock = std::chrono::steady_clock;
using dca::wire::Message;
using dca::wire::Value;

namespace {

void result(const char* bench, const std::string& variant, double wall_s, double sim_s, const std::string& extra) {
  const double per_ms_us = wall_s / (sim_s * 1000.0) * 1e6;
  std::printf("RESULT bench=%s variant=%s n=1 p50_us=%.1f p99_us=%.1f p999_us=%.1f max_us=%.1f rtf=%.2f%s\n", bench,
              variant.c_str(), per_ms_us, per_ms_us, per_ms_us, per_ms_us, sim_s / wall_s, extra.c_str());
  std::fflush(stdout);
}

double raw_world(double seconds) {
  dca::sim::World w(dca::sim::door_world());
  const auto t0 = Clock::now();
  const long steps = std::lround(seconds / w.config().period);
  for (long i = 0; i < steps; ++i) w.step();
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// One run: an in-process daemon on simulated time and the world, `nodes` spawned dca-node processes with
// Counter(period) running, `seconds` of simulated time. Returns the wall time of the simulated part (-1 on error).
double lockstep(int nodes, double period, double seconds, const dca::auth::Key& key, const std::string& key_file) {
  dca::Loop loop;
  dca::DaemonOptions dopts;
  dopts.host = "bench";
  dopts.key = key;
  dopts.sim_clock = true;
  const std::string lean = std::filesystem::path(DCA_EXE).parent_path() / "dca-node";
  dopts.allow.allow(lean);
  dca::Daemon daemon(loop.io(), dopts);
  std::string error;
  if (!daemon.start(&error)) {
    std::fprintf(stderr, "daemon: %s\n", error.c_str());
    return -1;
  }
  const std::string addr = daemon.address().str();
  dca::sim::World world(dca::sim::door_world());
  dca::sim::WorldNodeOptions wo;
  wo.duration = seconds;
  dca::sim::WorldNode wn(loop, world, wo);
  bool held = false;
  wn.on_duration = [&] { held = true; };
  dca::NodeOptions no;
  no.name = "world";
  no.daemon = addr;
  no.key_file = key_file;
  auto hosted = wn.make_node(no);
  dca::Node& wnode = *hosted;
  std::optional<std::string> started;
  wnode.start([&](const std::string& e) { started = e; });
  loop.run_until([&] { return started.has_value(); }, std::chrono::seconds(10));
  if (started.value_or("timeout") != "") {
    std::fprintf(stderr, "world: %s\n", started.value_or("timeout").c_str());
    return -1;
  }
  dca::ChannelOptions chopts{key};
  auto open = [&](const std::string& a) {
    dca::Channel::Ptr ch;
    std::string err;
    dca::Channel::connect(loop.io(), *dca::Address::parse(a), chopts, [&](dca::Channel::Ptr c, const std::string& e) {
      ch = c;
      err = e.empty() ? "connected" : e;
    });
    loop.run_until([&] { return !err.empty(); }, std::chrono::seconds(10));
    return ch;
  };
  auto call = [&](const dca::Channel::Ptr& ch, Message m) {
    std::optional<dca::Response> r;
    ch->request(std::move(m), std::chrono::seconds(20), [&](dca::Response x) { r = std::move(x); });
    loop.run_until([&] { return r.has_value(); }, std::chrono::seconds(25));
    return r.value_or(dca::Response{{}, "no answer"});
  };
  auto to_daemon = open(addr);
  if (!to_daemon) return -1;
  char per[32];
  std::snprintf(per, sizeof per, "%g", period);
  for (int i = 0; i < nodes; ++i) {
    const std::string name = "/bench/c" + std::to_string(i);
    auto s = call(to_daemon, {"spawn", 0,
                              Value::map()
                                  .set("argv", Value::Array{lean, "node", "--type", "Counter", "--name", name, "--daemon",
                                                            addr, "--key", key_file, "--", per})
                                  .set("name", name)});
    auto l = call(to_daemon, {"lookup", 0, Value::map().set("name", name).set("wait_ms", 5000)});
    if (!s.ok() || !l.ok()) {
      std::fprintf(stderr, "node %s: %s %s\n", name.c_str(), s.error.c_str(), l.error.c_str());
      return -1;
    }
    auto ctl = open(l.message.payload["endpoints"]["control"].as_string());
    if (!ctl || !call(ctl, {"run", 0, Value::map()}).ok()) return -1;
  }
  auto to_world = open(daemon.names().table().find("world")->endpoints["control"].as_string());
  const auto t0 = Clock::now();
  call(to_world, {"go", 0, Value::map()});
  loop.run_until([&] { return held; }, std::chrono::seconds(600));
  const double wall = std::chrono::duration<double>(Clock::now() - t0).count();
  const auto st = call(to_world, {"status", 0, Value::map()});
  if (st.message.payload["subscribers"].as_array().size() != static_cast<std::size_t>(nodes))
    std::fprintf(stderr, "warning: %zu subscribers, expected %d\n", st.message.payload["subscribers"].as_array().size(),
                 nodes);
  wnode.shutdown("bench over");
  daemon.stop();
  return held ? wall : -1;
}

}  // namespace

int main(int argc, char** argv) {
  const double seconds = argc > 1 ? std::max(0.1, std::atof(argv[1])) : 2.0;
  const std::string dir = std::filesystem::temp_directory_path() / ("dca-bench-lockstep-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string key_file = dir + "/key";
  std::string error;
  auto key = dca::auth::load_or_create_key(key_file, &error);
  if (!key) {
    std::fprintf(stderr, "%s\n", error.c_str());
    return 1;
  }
  struct Variant {
    int nodes;
    double period;
  };
  const Variant variants[] = {{0, 0.01}, {1, 0.001}, {1, 0.01}, {8, 0.01}, {20, 0.01}};
  for (int round = 0; round < 2; ++round) {
    for (const auto& v : variants) {
      std::fprintf(stderr, "round %d: raw world, then %d nodes at %g s\n", round + 1, v.nodes, v.period);
      result("raw_world_rtf", "step_1ms", raw_world(seconds), seconds, "");
      const double wall = lockstep(v.nodes, v.period, seconds, *key, key_file);
      if (wall < 0) {
        std::fprintf(stderr, "lock-step run failed\n");
        continue;
      }
      char extra[64];
      std::snprintf(extra, sizeof extra, " advances_per_s=%.0f", v.nodes * seconds / v.period / wall);
      result("lockstep_rtf", std::to_string(v.nodes) + "nodes_" + std::to_string(static_cast<int>(v.period * 1000)) + "ms",
             wall, seconds, extra);
    }
  }
  std::error_code ec;
  std::filesystem::remove_all(dir, ec);
  return 0;
}
