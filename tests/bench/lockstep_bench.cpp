// Lock-step simulated time across processes (BENCHMARKS.md format): how fast the world runs when N real node
// processes (`dca-node --clock sim`, Counter controllers) are advanced by it every tick, beside the raw world
// (World::step in a loop, no nodes, no sockets) in the same run, alternated A B A B.
//   RESULT bench=lockstep_rtf variant=<N>nodes_<P>ms ... rtf=<simulated s per wall s> per_tick_us=<wall per tick>
//   RESULT bench=raw_world_rtf variant=step_1ms ... rtf=...
// The latency fields are the wall time per simulated millisecond (one physics step), one sample per run.
// Usage: bench_lockstep [SIM_SECONDS]   (default 2)
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "host/loop.h"  // before any other Asio header
#include "worlds/door/world.h"
#include "tests/bench/bench_util.h"
#include "tests/support/key_dir.h"
#include "tests/support/sim_world.h"

using Clock = std::chrono::steady_clock;
using dca::wire::Value;

namespace {

// The RESULT line of one run: the wall time per simulated millisecond, and the real-time factor.
void result(const char* bench, const std::string& variant, double wall_s, double sim_s, const std::string& extra) {
  std::vector<double> per_ms_us{wall_s / (sim_s * 1000.0) * 1e6};
  char rtf[32];
  std::snprintf(rtf, sizeof rtf, " rtf=%.2f", sim_s / wall_s);
  dca::bench::result(bench, variant, per_ms_us, rtf + extra);
}

double raw_world(double seconds) {
  dca::sim::World w(dca::sim::door_world());
  const auto t0 = Clock::now();
  const long steps = std::lround(seconds / w.config().period);
  for (long i = 0; i < steps; ++i) w.step();
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// Spawns `nodes` dca-node processes with Counter(period) at the daemon and runs each; false on an error.
bool spawn_counters(dca::test::SimWorld& sim, int nodes, double period, const std::string& lean,
                    const std::string& key_file) {
  const std::string addr = sim.daemon.address().str();
  const auto wait = std::chrono::seconds(20);
  std::string error;
  auto to_daemon = sim.open(addr, &error);
  if (!to_daemon) return false;
  char per[32];
  std::snprintf(per, sizeof per, "%g", period);
  for (int i = 0; i < nodes; ++i) {
    const std::string name = "/bench/c" + std::to_string(i);
    const auto argv = Value::Array{lean, "node", "--type", "Counter", "--name", name, "--daemon", addr, "--key",
                                   key_file, "--", per};
    auto s = sim.call(to_daemon, "spawn", Value::map().set("argv", argv).set("name", name), wait);
    auto l = sim.call(to_daemon, "lookup", Value::map().set("name", name).set("wait_ms", 5000), wait);
    if (!s.ok() || !l.ok()) {
      std::fprintf(stderr, "node %s: %s %s\n", name.c_str(), s.error.c_str(), l.error.c_str());
      return false;
    }
    auto ctl = sim.open(l.message.payload["endpoints"]["control"].as_string(), &error);
    if (!ctl || !sim.call(ctl, "run", Value::map(), wait).ok()) return false;
  }
  return true;
}

// One run: an in-process daemon on simulated time and the world, `nodes` spawned dca-node processes with
// Counter(period) running, `seconds` of simulated time. Returns the wall time of the simulated part (-1 on error).
double lockstep(int nodes, double period, double seconds, const dca::test::KeyDir& keys) {
  dca::Loop loop;
  dca::DaemonOptions dopts;
  dopts.host = "bench";
  dopts.key = keys.key;
  dopts.sim_clock = true;
  const std::string lean = std::filesystem::path(DCA_EXE).parent_path() / "dca-node";
  dopts.allow.allow(lean);
  dca::sim::DeviceNodeOptions wo;
  wo.duration = seconds;
  dca::test::SimWorld sim(loop, dopts, wo, keys.key_file);
  std::string error;
  if (!sim.start(&error)) {
    std::fprintf(stderr, "world: %s\n", error.c_str());
    return -1;
  }
  if (!spawn_counters(sim, nodes, period, lean, keys.key_file)) return -1;
  auto to_world = sim.open(sim.control_of("world"), &error);
  const auto t0 = Clock::now();
  sim.call(to_world, "go", Value::map(), std::chrono::seconds(20));
  loop.run_until([&] { return sim.held; }, std::chrono::seconds(600));
  const double wall = std::chrono::duration<double>(Clock::now() - t0).count();
  const auto st = sim.call(to_world, "status", Value::map(), std::chrono::seconds(20));
  if (st.message.payload["subscribers"].as_array().size() != static_cast<std::size_t>(nodes))
    std::fprintf(stderr, "warning: %zu subscribers, expected %d\n", st.message.payload["subscribers"].as_array().size(),
                 nodes);
  sim.stop("bench over");
  return sim.held ? wall : -1;
}

}  // namespace

int main(int argc, char** argv) {
  const double seconds = argc > 1 ? std::max(0.1, std::atof(argv[1])) : 2.0;
  const dca::test::KeyDir keys("bench-lockstep");
  if (!keys.ok()) {
    std::fprintf(stderr, "%s\n", keys.error.c_str());
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
      const double wall = lockstep(v.nodes, v.period, seconds, keys);
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
  return 0;
}
