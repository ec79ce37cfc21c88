// `dca sim`: runs a world (sim/world_plugin.h, docs/worlds.md) here, or serves it as the world process of a run in
// simulated time (`--serve`, sim/device_node.h). Nothing here knows a world by name: a world's own options come
// through `--world-opt KEY=VALUE` and the world checks them.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "app/node_run.h"
#include "app/subcommand.h"
#include "bindings/core.h"
#include "host/loop.h"
#include "host/node.h"
#include "host/timers.h"
#include "sim/device_node.h"
#include "sim/world_plugin.h"

namespace dca::cli::cmd_sim {
namespace {

constexpr const char* kUsage =
    "usage: dca sim [--world WORLD] [--world-opt KEY[=VALUE]]... [--seed N] [--duration S] [--period S]\n"
    "               [--record FILE] [--record-period S] [--realtime]\n"
    "       dca sim --serve --daemon ADDR [--name world] [--key FILE] [--host NAME] [--go] [--sync S]\n"
    "               [--tick-timeout MS] [--spin auto|off|US] [--trace FILE] [world options as above]\n"
    "       dca sim --worlds\n\n"
    "Runs a simulated world at a fixed control period (default 0.001 s), as fast as the machine allows or, with\n"
    "--realtime, paced to the wall clock. WORLD is a world's name (`dca sim --worlds` lists them with their\n"
    "options; default: $DCA_WORLD, else the first), ROBOT.urdf or mock:ROBOT.urdf[?lag=S&dead=J,...] (the\n"
    "generic URDF world, docs/robots.md). Run here, each world does what it documents (a world with a run of\n"
    "its own, e.g. a scripted task; a URDF world steps --duration seconds with no commands and prints its\n"
    "signals).\n\n"
    "  --world-opt K=V   one of the world's own options (repeatable; a flag alone: --world-opt K)\n"
    "  --seed N          the world's random draw (a world without one ignores it)\n"
    "  --duration S      simulated seconds to run (default: the world's); served, time holds after S\n"
    "  --record FILE     record the world's signals every --record-period seconds (default 0.01): FILE.mcap as\n"
    "                    MCAP (log time = simulated time; Foxglove, Lichtblick and PlotJuggler open it); a world\n"
    "                    with a CSV export of its own takes any other name as CSV\n"
    "  --record-compression zstd|lz4|none   an MCAP recording's chunks (default zstd: docs/recording.md)\n"
    "  --record-split SIZE|DURATION        FILE-000.mcap, FILE-001.mcap, ... each of at most about SIZE (100MB,\n"
    "                    1GiB) or DURATION of simulated time (60s, 10min, 1h), each with every channel\n"
    "  --record-profile ros2   the MCAP `ros2` profile: message ports' channels as CDR with ros2msg schemas (the\n"
    "                    rest stays JSON; docs/recording.md, \"The ros2 profile\")\n\n"
    "--serve: the world as a process (sim/device_node.h): registers NAME (default `world`) with the daemon at\n"
    "ADDR, its ports are the world's signals (`dca types --world WORLD`), and it is the clock master of every\n"
    "node on simulated time (`dca node --clock sim`): time starts at 0 on `go` (or at once with --go) and\n"
    "advances in lock-step with the nodes that subscribed. --duration holds time after S seconds; --realtime\n"
    "paces it. Prints `dca sim: world ready` once registered and a summary when it exits.\n"
    "  --sync S             every subscriber is advanced at least every S seconds (default 0.01)\n"
    "  --tick-timeout MS    a node that does not answer an advance in MS is dropped from the clock (10000)\n"
    "  --spin auto|off|US   nodes poll for their next advance for US µs after answering one, and the world for\n"
    "                       the answers (auto: 2000 while every process on the clock has a CPU of its own)\n"
    "  --record-outputs     with --record FILE.mcap: the world's outputs as published too, exactly, on\n"
    "                       /dca/world/outputs (what `--world replay:FILE.mcap` serves again)\n"
    "  --blackbox B,A[,MB]  with --record FILE.mcap: a black box instead (docs/recording.md): the last B s held\n"
    "                       (at most MB MiB, default 64), written with A s after a fault or a `blackbox` request\n"
    "                       to FILE-1.mcap, FILE-2.mcap, ...; also on the first refusal of a second writer, and\n"
    "                       a storm of limit clamps (--blackbox-storm N,S: N clamped within S s, default 10,1)\n"
    "  --trace FILE         writes the lock-step trace: every output's samples per tick (count, digest, value),\n"
    "                       set switches, events, lost nodes (`dca trace diff` compares two)\n\n"
    "Exit code 0 on success, 1 if the world fails or cannot be built, 2 on a usage error.";

struct Options {
  std::string world;
  std::vector<std::string> world_opts;
  bool serve = false, go = false, realtime = false, list = false, record_outputs = false, blackbox = false;
  dca::sim::BlackboxOptions box;
  dca::sim::RecordOptions recording;
  std::string daemon, name = "world", key, host, trace, record;
  std::uint64_t seed = 0;
  double duration = -1, period = 1e-3, record_period = 0.01, sync_period = 0.01;
  int tick_timeout_ms = 10000;
  int spin_us = -1;  // --spin: -1 auto, 0 off
};

int usage_error(const std::string& why) {
  std::fprintf(stderr, "dca sim: %s\n%s\n", why.c_str(), kUsage);
  return 2;
}

std::optional<double> number(const char* s) {
  char* end = nullptr;
  const double v = std::strtod(s, &end);
  if (end == s || *end != '\0' || !std::isfinite(v)) return std::nullopt;
  return v;
}

// Sets flag `a` (an option without a value): false when `a` is no flag.
bool set_flag(const std::string& a, Options& o) {
  bool* flag = a == "--realtime" ? &o.realtime : a == "--serve" ? &o.serve : a == "--go" ? &o.go
               : a == "--worlds" ? &o.list : a == "--record-outputs" ? &o.record_outputs : nullptr;
  if (flag != nullptr) *flag = true;
  return flag != nullptr;
}

// Reads `v` (nullptr: missing) as a positive number into `out`: false when it is not one.
bool positive(const char* v, double& out) {
  const auto n = v ? number(v) : std::nullopt;
  if (!n || *n <= 0) return false;
  out = *n;
  return true;
}

// --blackbox B,A[,MB]: "" or what is wrong with it.
std::string blackbox(const char* v, Options& o) {
  double b = -1, a = -1, mb = 64;
  char tail = 0;
  const int n = v ? std::sscanf(v, "%lf,%lf,%lf%c", &b, &a, &mb, &tail) : 0;
  if ((n != 2 && n != 3) || !(b >= 0 && a >= 0 && mb > 0 && b < 1e6 && a < 1e6 && mb < 1e6))
    return "--blackbox needs SECONDS_BEFORE,SECONDS_AFTER[,MIB] (non-negative seconds, e.g. 5,1)";
  o.blackbox = true;
  o.box.before = b, o.box.after = a, o.box.max_bytes = static_cast<std::size_t>(mb * 1024 * 1024);
  return "";
}

// --blackbox-storm N,SECONDS: "" or what is wrong with it.
std::string storm(const char* v, Options& o) {
  double n = 0, w = 0;
  char tail = 0;
  if (!v || std::sscanf(v, "%lf,%lf%c", &n, &w, &tail) != 2 || !(n >= 1 && n < 1e9 && w > 0 && w < 1e6))
    return "--blackbox-storm needs CLAMPS,SECONDS (at least 1 clamp within positive seconds, e.g. 10,1)";
  o.box.storm_clamps = static_cast<std::uint64_t>(n), o.box.storm_window = w;
  return "";
}

// Applies option `a` with value `v` (nullptr: missing): "" or what is wrong with it.
std::string set_value(const std::string& a, const char* v, Options& o) {
  if (a == "--seed") {
    char* end = nullptr;
    if (!v || *v == '-' || (o.seed = std::strtoull(v, &end, 10), *end != '\0'))
      return "--seed needs a non-negative integer";
    return "";
  }
  if (a == "--duration") return positive(v, o.duration) ? "" : "--duration needs positive seconds";
  if (a == "--period")
    return positive(v, o.period) && o.period <= 0.01 ? "" : "--period needs seconds in (0, 0.01]";
  if (a == "--record-period") return positive(v, o.record_period) ? "" : "--record-period needs positive seconds";
  if (a == "--blackbox") return blackbox(v, o);
  if (a == "--record-compression")
    return v && dca::mcap::parse_compression(v, &o.recording.compression) && *v ? ""
           : "--record-compression needs zstd, lz4 or none";
  if (a == "--record-split")
    return v && dca::sim::parse_split(v, &o.recording) ? ""
           : "--record-split needs a size (100MB, 1GiB: at least 4096 bytes) or a duration (60s, 10min, 1h)";
  if (a == "--record-profile") {
    if (!v || std::string(v) != "ros2") return "--record-profile needs ros2";
    o.recording.profile = v;
    return "";
  }
  if (a == "--blackbox-storm") return storm(v, o);
  if (a == "--sync") return positive(v, o.sync_period) ? "" : "--sync needs positive seconds";
  if (a == "--spin") {
    const std::string w = v ? v : "";
    char* end = nullptr;
    const long us = w == "auto" ? -1 : w == "off" ? 0 : std::strtol(w.c_str(), &end, 10);
    if (w != "auto" && w != "off" && (w.empty() || *end != '\0' || us <= 0 || us > 100000))
      return "--spin needs auto, off or microseconds from 1 to 100000";
    o.spin_us = static_cast<int>(us);
    return "";
  }
  if (a == "--tick-timeout") {
    double ms = 0;
    if (!positive(v, ms)) return "--tick-timeout needs positive milliseconds";
    o.tick_timeout_ms = static_cast<int>(ms);
    return "";
  }
  if (!v || !*v) return a + " needs a value";
  if (a == "--world-opt") return o.world_opts.emplace_back(v), "";
  std::string* text = a == "--world" ? &o.world : a == "--record" ? &o.record : a == "--trace" ? &o.trace
                      : a == "--daemon" ? &o.daemon : a == "--name" ? &o.name : a == "--key" ? &o.key
                      : a == "--host" ? &o.host : nullptr;
  if (text == nullptr) return "unknown argument '" + a + "' (a world's own options: --world-opt KEY=VALUE)";
  *text = v;
  return "";
}

// Parses argv into `o`: 0, or 2 after printing the usage error.
int parse(std::span<char* const> args, Options& o) {
  static const std::string kValued =
      " --world --world-opt --seed --duration --period --record-period --record --trace --daemon --name --key"
      " --host --sync --tick-timeout --spin --blackbox --blackbox-storm --record-compression --record-split"
      " --record-profile ";
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string a = args[i];
    if (set_flag(a, o)) continue;
    const bool valued = kValued.find(" " + a + " ") != std::string::npos;
    const char* v = valued && i + 1 < args.size() ? args[++i] : nullptr;
    if (const std::string why = set_value(a, v, o); !why.empty()) return usage_error(why);
  }
  return 0;
}

// `dca sim --worlds`: every world with its options.
int list_worlds() {
  for (const auto* p : dca::sim::worlds()) {
    std::printf("%s: %s\n", p->name.empty() ? "ROBOT.urdf, mock:ROBOT.urdf" : p->name.c_str(), p->summary.c_str());
    std::fputs(dca::sim::world_options_help(*p).c_str(), stdout);
  }
  return 0;
}

void print_lines(const char* prefix, const std::vector<std::string>& lines) {
  for (const auto& l : lines) std::printf("%s%s\n", prefix, l.c_str());
}

// --serve: the world process (sim/device_node.h).
int serve(const Options& o, dca::sim::DeviceWorld& world) {
  dca::Loop loop;
  dca::sim::DeviceNodeOptions dno;
  dno.sync_period = o.sync_period;
  dno.tick_timeout_ms = o.tick_timeout_ms;
  dno.spin_us = o.spin_us;
  dno.realtime = o.realtime;
  dno.duration = o.duration;
  dno.trace = o.trace;
  dno.record = o.record, dno.record_period = o.record_period, dno.record_outputs = o.record_outputs;
  dno.blackbox = o.blackbox, dno.box = o.box, dno.recording = o.recording;
  dca::sim::DeviceNode dn(loop, world, dno);
  dca::NodeOptions no;
  no.name = o.name;
  no.daemon = o.daemon;
  no.key_file = o.key;
  no.host = o.host;
  auto node = dn.make_node(no);
  const auto wall0 = std::chrono::steady_clock::now();
  bool ready = false;
  std::string failure;
  dca::app::run_node(loop, *node, [&] {
    std::printf("dca sim: world ready (%s): %s, period %g s\n", o.name.c_str(), world.describe().c_str(), world.period());
    print_lines("dca sim: warning: ", world.warnings());
    std::fflush(stdout);
    if (o.go) dn.go();
  }, &ready, &failure);
  node->shutdown(failure.empty() ? "world exiting" : "start-up failed");
  if (!failure.empty()) {
    std::fprintf(stderr, "dca sim: %s\n", failure.c_str());
    return 1;
  }
  if (!dn.stuck().empty()) return 1;  // said (DeviceNode): the run that drove it hears of the exit
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  print_lines("dca sim: ", world.summary());
  std::printf("dca sim: simulated %.3f s in %.3f s wall\n", dca::to_seconds(dn.now()), wall);
  return node->exit_code();
}

// No --serve, and a world without a run of its own: steps --duration seconds (default 1) with no commands.
int step_here(const Options& o, dca::sim::DeviceWorld& world) {
  const double end = o.duration > 0 ? o.duration : 1.0;
  std::printf("dca sim: %s, period %g s, no commands\n", world.describe().c_str(), world.period());
  print_lines("dca sim: warning: ", world.warnings());
  const auto wall0 = std::chrono::steady_clock::now();
  long steps = 0;
  while (world.time() < end - 1e-9) world.step(), ++steps;
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  std::vector<double> v;
  for (std::size_t i = 0; i < world.sensors().size(); ++i) {
    v.resize(world.sensors()[i].size);
    world.sensor(i, v.data());
    std::printf("%s:", world.sensors()[i].name.c_str());
    for (const double x : v) std::printf(" %.6f", x);
    std::printf("\n");
  }
  print_lines("", world.summary());
  std::printf("simulated %.3f s in %.3f s wall, %ld steps\n", world.time(), wall, steps);
  return 0;
}

// The world's setup from the options: false with *error (an unknown world, a bad option).
bool setup_of(const Options& o, dca::sim::WorldSetup* setup, const dca::sim::WorldPlugin** plugin, std::string* error) {
  setup->spec = o.world.empty() ? dca::sim::default_world() : o.world;
  setup->seed = o.seed;
  setup->period = o.period;
  *plugin = dca::sim::find_world(setup->spec);
  if (*plugin == nullptr) {
    *error = "--world: no world '" + setup->spec + "' (`dca sim --worlds` lists them; or ROBOT.urdf, mock:ROBOT.urdf)";
    return false;
  }
  return dca::sim::parse_world_options(**plugin, o.world_opts, &setup->options, error);
}

int cmd_sim(std::span<char* const> args) {
  Options o;
  if (const int code = parse(args, o); code != 0) return code;
  if (o.list) return list_worlds();
  dca::sim::WorldSetup setup;
  const dca::sim::WorldPlugin* plugin = nullptr;
  if (std::string why; !setup_of(o, &setup, &plugin, &why)) return usage_error(why);
  if (o.serve && o.daemon.empty()) return usage_error("--serve needs --daemon ADDR");
  try {
    if (!o.serve && plugin->run_local) {
      dca::sim::LocalRun local{o.duration, o.realtime, o.record, o.record_period, o.recording};
      return plugin->run_local(setup, local);
    }
    if (!o.serve && !o.record.empty()) return usage_error("--record with this world goes with --serve (dca run --sim WORLD --record)");
    auto world = plugin->make(setup);
    return o.serve ? serve(o, *world) : step_here(o, *world);
  } catch (const std::invalid_argument& e) {
    return usage_error(e.what());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dca sim: %s\n", e.what());
    return 1;
  }
}

// The signals of world `spec`, for dca check's device ports (bindings/core.h): those `dca sim --serve --world
// SPEC` hosts as ports; "" is the default world. Its options are checked; they do not change its signals.
bool world_signals(const std::string& spec, const std::vector<std::string>& options,
                   dca::bindings::WorldSignals* out, std::string* error) {
  dca::sim::WorldSetup setup;
  setup.spec = spec.empty() ? dca::sim::default_world() : spec;
  out->world = setup.spec;
  const dca::sim::WorldPlugin* p = dca::sim::find_world(setup.spec);
  if (p == nullptr || !p->signals) {
    *error = "world '" + setup.spec + "': no such world (`dca sim --worlds` lists them; or ROBOT.urdf, mock:ROBOT.urdf)";
    return false;
  }
  if (!dca::sim::parse_world_options(*p, options, &setup.options, error)) return false;
  std::vector<dca::sim::DeviceSignal> sensors, commands;
  try {
    p->signals(setup, &sensors, &commands);
  } catch (const std::exception& e) {
    *error = e.what();
    return false;
  }
  for (const auto& x : sensors) out->outputs.push_back(dca::vector_port(x.name, x.size, x.units));
  for (const auto& x : commands) {
    out->inputs.push_back(dca::vector_port(x.name, x.size, x.units));
    if (!x.actuator.empty()) out->actuators.emplace_back(x.name, x.actuator);
  }
  out->inputs.push_back(dca::vector_port(dca::sim::kEstopInput, 1, ""));  // every world's (sim/device_node.h)
  return true;
}

[[maybe_unused]] const bool kWorldSignalsRegistered = [] {
  dca::bindings::set_world_signals(&world_signals);
  return true;
}();

}  // namespace

DCA_SUBCOMMAND("sim", "run a simulated world (Simbody) in lock-step or real time, or serve it to a run", kUsage, cmd_sim);

}  // namespace dca::cli::cmd_sim
