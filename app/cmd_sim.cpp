// `dca sim`: runs the simulated door world in its own lock-step loop (as fast as possible, or paced to the
// wall clock with --realtime), driven by an open-loop script or the built-in scripted door opening.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <span>
#include <string>
#include <thread>

#include <csignal>

#include "app/subcommand.h"
#include "host/loop.h"
#include "host/node.h"
#include "sim/door_script.h"
#include "sim/recorder.h"
#include "sim/script.h"
#include "sim/world.h"
#include "sim/world_node.h"

namespace {

constexpr const char* kUsage =
    "usage: dca sim [--world door] [--seed N] [--door-width W] [--duration S] [--period S] [--script FILE]\n"
    "               [--record FILE.csv] [--record-period S] [--realtime] [--visualize]\n"
    "               [--jammed]\n"
    "               [--print-door-urdf]\n"
    "       dca sim --serve --daemon ADDR [--name world] [--key FILE] [--host NAME] [--go] [--sync S]\n"
    "               [--command-timeout S] [--tick-timeout MS] [world options as above]\n\n"
    "Runs the simulated world (the mobile manipulator and the door, Simbody, from sim/models/) in lock-step\n"
    "at a fixed control period (default 0.001 s), as fast as the machine allows or, with --realtime, paced to\n"
    "the wall clock. Without --script the built-in scripted door opening drives the robot (drive to the door,\n"
    "grasp, press the handle, push the door to 75 degrees) and the run ends when it is done.\n\n"
    "  --seed N          start pose within +-0.3 m / +-15 deg of the nominal one and a door 0.8-1.0 m wide,\n"
    "                    drawn from N (0, the default: the nominal pose and a 0.9 m door)\n"
    "  --door-width W    the door's width in metres (overrides the seed's)\n"
    "  --duration S      simulated seconds to run (default: until the script or the door opening ends)\n"
    "  --script FILE     open-loop commands, one `TIME WORD ARGS` per line (see sim/script.h):\n"
    "                    base VX VY WZ | arm Q1..Q6 | gripper open|close | stop | door | end\n"
    "  --record FILE.csv record time, joint angles, base pose, wrench, door and handle angles (see\n"
    "                    `dca plot`), every --record-period seconds (default 0.01)\n"
    "  --visualize       show the world in Simbody's 3-D visualizer where a display exists (else a warning)\n"
    "  --jammed          a fault: the handle is seized and the latch never releases\n"
    "  --print-door-urdf print the door's URDF for the chosen width and exit\n\n"
    "--serve: the world as a process (sim/world_node.h): registers NAME (default `world`) with the daemon at\n"
    "ADDR, its ports are the world's signals (sim/world.h), and it is the clock master of every node on\n"
    "simulated time (`dca node --clock sim`): time starts at 0 on `go` (or at once with --go) and advances in\n"
    "lock-step with the nodes that subscribed. --duration holds time after S seconds; --realtime paces it.\n"
    "Prints `dca sim: world ready` once registered and a summary when it exits (`exit` request or SIGTERM).\n"
    "  --sync S             every subscriber is advanced at least every S seconds (default 0.01)\n"
    "  --command-timeout S  base and arm commands older than S count as zero (default 0.05)\n"
    "  --tick-timeout MS    a node that does not answer an advance in MS is dropped from the clock (10000)\n\n"
    "Prints each step of the door opening as it starts and a summary (`door opened to NN.N deg`). Exit code 0\n"
    "on success, 1 if the scripted opening fails or the world cannot be built, 2 on a usage error.";

struct Options {
  bool serve = false, go = false;
  std::string daemon, name = "world", key, host;
  dca::sim::WorldNodeOptions node;
  std::uint64_t seed = 0;
  double door_width = 0, duration = -1, period = 1e-3, record_period = 0.01;
  std::string script, record;
  bool realtime = false, print_urdf = false, visualize = false, jammed = false;
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

// --serve: the world process (sim/world_node.h).
int serve(const Options& o, const dca::sim::WorldConfig& config) {
  if (o.daemon.empty()) return usage_error("--serve needs --daemon ADDR");
  if (!o.script.empty()) return usage_error("--serve takes no --script: the nodes drive the robot");
  try {
    dca::sim::World world(config);
    if (o.visualize) {
      std::string why;
      if (!world.start_visualizer(&why))
        std::fprintf(stderr, "dca sim: --visualize: %s; running without it\n", why.c_str());
    }
    dca::Loop loop;
    dca::sim::WorldNodeOptions wo = o.node;
    wo.realtime = o.realtime;
    wo.duration = o.duration;
    wo.record = o.record;
    wo.record_period = o.record_period;
    dca::sim::WorldNode wn(loop, world, wo);
    dca::NodeOptions no;
    no.name = o.name;
    no.daemon = o.daemon;
    no.key_file = o.key;
    no.host = o.host;
    auto hosted = wn.make_node(no);
    dca::Node& node = *hosted;
    loop.on_signals({SIGTERM, SIGINT}, [&](int) { loop.stop(); });
    std::string failure;
    node.start([&](const std::string& error) {
      if (!error.empty()) {
        failure = error;
        loop.stop();
        return;
      }
      std::printf("dca sim: world ready (%s), door %.3f m wide, robot at (%.3f, %.3f, %.1f deg), period %g s\n",
                  o.name.c_str(), config.door.width, config.base_start.x, config.base_start.y,
                  config.base_start.yaw * 180 / M_PI, config.period);
      std::fflush(stdout);
      if (o.go) wn.go();
    });
    const auto wall0 = std::chrono::steady_clock::now();
    loop.run();
    node.shutdown(failure.empty() ? "world exiting" : "start-up failed");
    if (!failure.empty()) {
      std::fprintf(stderr, "dca sim: %s\n", failure.c_str());
      return 1;
    }
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
    const double t = dca::to_seconds(wn.now());
    std::printf("dca sim: door at %.1f deg; simulated %.3f s in %.3f s wall\n", world.sensors().door_angle * 180 / M_PI,
                t, wall);
    return node.exit_code();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dca sim: %s\n", e.what());
    return 1;
  }
}

int cmd_sim(std::span<char* const> args) {
  Options o;
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string a = args[i];
    const auto value = [&]() -> const char* { return i + 1 < args.size() ? args[++i] : nullptr; };
    const auto positive = [&](double& out, bool allow_zero) {
      const char* v = value();
      const auto n = v ? number(v) : std::nullopt;
      if (!n || *n < 0 || (!allow_zero && *n == 0)) return false;
      out = *n;
      return true;
    };
    if (a == "--world") {
      const char* v = value();
      if (!v || std::string(v) != "door") return usage_error("--world: the only world is 'door'");
    } else if (a == "--seed") {
      const char* v = value();
      char* end = nullptr;
      if (!v || *v == '-') return usage_error("--seed needs a non-negative integer");
      o.seed = std::strtoull(v, &end, 10);
      if (*end != '\0') return usage_error("--seed needs a non-negative integer");
    } else if (a == "--door-width") {
      if (!positive(o.door_width, false) || o.door_width < 0.5 || o.door_width > 1.5)
        return usage_error("--door-width needs a width in metres, 0.5-1.5");
    } else if (a == "--duration") {
      if (!positive(o.duration, false)) return usage_error("--duration needs positive seconds");
    } else if (a == "--period") {
      if (!positive(o.period, false) || o.period > 0.01) return usage_error("--period needs seconds in (0, 0.01]");
    } else if (a == "--record-period") {
      if (!positive(o.record_period, false)) return usage_error("--record-period needs positive seconds");
    } else if (a == "--script") {
      const char* v = value();
      if (!v) return usage_error("--script needs a file");
      o.script = v;
    } else if (a == "--record") {
      const char* v = value();
      if (!v) return usage_error("--record needs a file");
      o.record = v;
    } else if (a == "--realtime") {
      o.realtime = true;
    } else if (a == "--visualize") {
      o.visualize = true;
    } else if (a == "--serve") {
      o.serve = true;
    } else if (a == "--go") {
      o.go = true;
    } else if (a == "--daemon" || a == "--name" || a == "--key" || a == "--host") {
      const char* v = value();
      if (!v || !*v) return usage_error(a + " needs a value");
      (a == "--daemon" ? o.daemon : a == "--name" ? o.name : a == "--key" ? o.key : o.host) = v;
    } else if (a == "--sync") {
      if (!positive(o.node.sync_period, false)) return usage_error("--sync needs positive seconds");
    } else if (a == "--command-timeout") {
      if (!positive(o.node.command_timeout, false)) return usage_error("--command-timeout needs positive seconds");
    } else if (a == "--tick-timeout") {
      double ms = 0;
      if (!positive(ms, false)) return usage_error("--tick-timeout needs positive milliseconds");
      o.node.tick_timeout_ms = static_cast<int>(ms);
    } else if (a == "--jammed") {
      o.jammed = true;
    } else if (a == "--print-door-urdf") {
      o.print_urdf = true;
    } else {
      return usage_error("unknown argument '" + a + "'");
    }
  }

  dca::sim::WorldConfig config = dca::sim::door_world(o.seed, o.door_width);
  config.period = o.period;
  if (o.jammed) config.door.handle_jammed = config.door.latch_jammed = true;
  if (o.print_urdf) {
    std::fputs(dca::sim::door_urdf(config.door).c_str(), stdout);
    return 0;
  }
  if (o.serve) return serve(o, config);
  try {
    std::optional<dca::sim::Script> script;
    std::string error;
    if (!o.script.empty() && !dca::sim::Script::load(o.script, &script.emplace(), &error)) {
      std::fprintf(stderr, "dca sim: %s\n", error.c_str());
      return 1;
    }
    dca::sim::World world(config);
    if (o.visualize) {
      std::string why;
      if (!world.start_visualizer(&why))
        std::fprintf(stderr, "dca sim: --visualize: %s; running without it\n", why.c_str());
    }
    std::optional<dca::sim::Recorder> recorder;
    if (!o.record.empty()) recorder.emplace(o.record);
    dca::sim::ScriptedDoorOpening door;
    const bool door_from_start = !script;
    double end = o.duration;
    if (end < 0) end = script && script->end_time() >= 0 ? script->end_time() : 120.0;

    std::printf("dca sim: door world, seed %llu, door %.3f m wide, robot at (%.3f, %.3f, %.1f deg), period %g s%s\n",
                static_cast<unsigned long long>(o.seed), config.door.width, config.base_start.x,
                config.base_start.y, config.base_start.yaw * 180 / M_PI, config.period,
                o.realtime ? ", real time" : ", lock-step");
    std::fflush(stdout);
    dca::sim::Commands commands;
    auto phase = dca::sim::DoorPhase::drive;
    bool door_active = false;
    double done_at = -1;
    const int record_every = std::max(1, static_cast<int>(std::lround(o.record_period / config.period)));
    const auto wall0 = std::chrono::steady_clock::now();
    long steps = 0;
    if (recorder) recorder->record(world.sensors(), -1);
    while (world.time() < end - 1e-9) {
      if (script && !script->advance(world.time(), commands)) break;
      if (door_from_start || (script && script->door_mode())) {
        if (!door_active) {
          door_active = true;
          std::printf("%9.3f s  drive\n", world.time());
        }
        commands = door.update(world);
        if (door.phase() != phase) {
          phase = door.phase();
          if (phase == dca::sim::DoorPhase::failed)
            std::printf("%9.3f s  failed: %s\n", world.time(), door.failure().c_str());
          else
            std::printf("%9.3f s  %s\n", world.time(), dca::sim::to_string(phase));
          std::fflush(stdout);
          if (phase == dca::sim::DoorPhase::done || phase == dca::sim::DoorPhase::failed) done_at = world.time();
        }
        if (done_at >= 0 && o.duration < 0 && world.time() >= done_at + 0.5) break;
      }
      world.set_commands(commands);
      world.step();
      ++steps;
      if (recorder && steps % record_every == 0) recorder->record(world.sensors(), door_active ? static_cast<int>(phase) : -1);
      if (o.realtime)
        std::this_thread::sleep_until(wall0 + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                                  std::chrono::duration<double>(world.time())));
    }
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
    if (recorder && !recorder->close(&error)) {
      std::fprintf(stderr, "dca sim: %s\n", error.c_str());
      return 1;
    }
    const auto& s = world.sensors();
    std::printf("door opened to %.1f deg\n", s.door_angle * 180 / M_PI);
    std::printf("simulated %.3f s in %.3f s wall (%.1fx real time), %ld steps\n", world.time(), wall,
                wall > 0 ? world.time() / wall : 0.0, steps);
    if (door_active) {
      std::printf("steps:");
      for (int p = 0; p <= static_cast<int>(dca::sim::DoorPhase::done); ++p)
        if (door.phase_start(static_cast<dca::sim::DoorPhase>(p)) >= 0)
          std::printf(" %s@%.3f", dca::sim::to_string(static_cast<dca::sim::DoorPhase>(p)),
                      door.phase_start(static_cast<dca::sim::DoorPhase>(p)));
      std::printf("\n");
    }
    if (recorder) std::printf("recorded %s\n", o.record.c_str());
    if (door_active && door.phase() == dca::sim::DoorPhase::failed) {
      std::fprintf(stderr, "dca sim: the scripted door opening failed: %s\n", door.failure().c_str());
      return 1;
    }
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dca sim: %s\n", e.what());
    return 1;
  }
}

}  // namespace

DCA_SUBCOMMAND("sim", "run the simulated door world (Simbody) in lock-step or real time", kUsage, cmd_sim);
