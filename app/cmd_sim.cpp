// `dca sim`: runs the simulated door world in its own lock-step loop (as fast as possible, or paced to the
// wall clock with --realtime), driven by an open-loop script or the built-in scripted door opening.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <span>
#include <string>
#include <thread>

#include <csignal>

#include "app/node_run.h"
#include "app/sim_robot.h"
#include "app/subcommand.h"
#include "bindings/core.h"
#include "host/loop.h"
#include "host/node.h"
#include "sim/door_script.h"
#include "sim/recorder.h"
#include "sim/script.h"
#include "sim/world.h"
#include "sim/world_node.h"

namespace {

constexpr const char* kUsage =
    "usage: dca sim [--world door|ROBOT.urdf|mock:ROBOT.urdf] [--seed N] [--door-width W] [--duration S] [--period S] [--script FILE]\n"
    "               [--record FILE.mcap|FILE.csv] [--record-period S] [--realtime] [--visualize]\n"
    "               [--jammed]\n"
    "               [--print-door-urdf]\n"
    "       dca sim --serve --daemon ADDR [--name world] [--key FILE] [--host NAME] [--go] [--sync S]\n"
    "               [--command-timeout S] [--tick-timeout MS] [--trace FILE] [world options as above]\n\n"
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
    "  --record FILE     record joint angles, base pose, wrench, door and handle angles, gripper, laser\n"
    "                    (see `dca plot`) every --record-period seconds (default 0.01): FILE.mcap as MCAP\n"
    "                    (one JSON channel per signal group, log time = simulated time; Foxglove, Lichtblick\n"
    "                    and PlotJuggler open it), any other name as CSV\n"
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
    "  --tick-timeout MS    a node that does not answer an advance in MS is dropped from the clock (10000)\n"
    "  --trace FILE         writes the lock-step trace: every output's samples per tick (count, digest, value),\n"
    "                       set switches, events, lost nodes (`dca trace diff` compares two)\n\n"
    "--world ROBOT.urdf or mock:ROBOT.urdf: the generic URDF world instead of the door (docs/robots.md):\n"
    "the robot's joint interfaces as ports (`dca types --world ROBOT.urdf` lists them); without --serve it\n"
    "steps --duration seconds (default 1) with no commands and prints the joints. It takes --period,\n"
    "--duration, --realtime and the --serve options, and with --serve --record FILE.mcap (its signals and link\n"
    "frames, docs/recording.md); --seed is ignored; the door's options are refused.\n\n"
    "Prints each step of the door opening as it starts and a summary (`door opened to NN.N deg`). Exit code 0\n"
    "on success, 1 if the scripted opening fails or the world cannot be built, 2 on a usage error.";

struct Options {
  std::string world;  // a robot world's spec ("" = the door)
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
    const auto wall0 = std::chrono::steady_clock::now();
    bool ready = false;
    std::string failure;
    dca::app::run_node(loop, node, [&] {
      std::printf("dca sim: world ready (%s), door %.3f m wide, robot at (%.3f, %.3f, %.1f deg), period %g s\n",
                  o.name.c_str(), config.door.width, config.base_start.x, config.base_start.y,
                  config.base_start.yaw * 180 / M_PI, config.period);
      std::fflush(stdout);
      if (o.go) wn.go();
    }, &ready, &failure);
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

// Sets flag `a` (an option without a value): false when `a` is no flag.
bool set_flag(const std::string& a, Options& o) {
  bool* flag = a == "--realtime"          ? &o.realtime
               : a == "--visualize"       ? &o.visualize
               : a == "--serve"           ? &o.serve
               : a == "--go"              ? &o.go
               : a == "--jammed"          ? &o.jammed
               : a == "--print-door-urdf" ? &o.print_urdf
                                          : nullptr;
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

// Applies option `a` with value `v` (nullptr: missing): "" or what is wrong with it.
std::string set_value(const std::string& a, const char* v, Options& o) {
  if (a == "--world") {
    if (v && std::string(v) == "door") return "";
    if (!v || !dca::app::is_robot_world(v)) return "--world: 'door', ROBOT.urdf or mock:ROBOT.urdf[?lag=S&dead=J,...]";
    o.world = v;
    return "";
  }
  if (a == "--seed") {
    char* end = nullptr;
    if (!v || *v == '-' || (o.seed = std::strtoull(v, &end, 10), *end != '\0'))
      return "--seed needs a non-negative integer";
    return "";
  }
  if (a == "--door-width")
    return positive(v, o.door_width) && o.door_width >= 0.5 && o.door_width <= 1.5
               ? "" : "--door-width needs a width in metres, 0.5-1.5";
  if (a == "--duration") return positive(v, o.duration) ? "" : "--duration needs positive seconds";
  if (a == "--period")
    return positive(v, o.period) && o.period <= 0.01 ? "" : "--period needs seconds in (0, 0.01]";
  if (a == "--record-period") return positive(v, o.record_period) ? "" : "--record-period needs positive seconds";
  if (a == "--script" || a == "--record" || a == "--trace") {
    if (!v) return a + " needs a file";
    (a == "--script" ? o.script : a == "--record" ? o.record : o.node.trace) = v;
    return "";
  }
  if (a == "--daemon" || a == "--name" || a == "--key" || a == "--host") {
    if (!v || !*v) return a + " needs a value";
    (a == "--daemon" ? o.daemon : a == "--name" ? o.name : a == "--key" ? o.key : o.host) = v;
    return "";
  }
  if (a == "--sync") return positive(v, o.node.sync_period) ? "" : "--sync needs positive seconds";
  if (a == "--command-timeout")
    return positive(v, o.node.command_timeout) ? "" : "--command-timeout needs positive seconds";
  if (a == "--tick-timeout") {
    double ms = 0;
    if (!positive(v, ms)) return "--tick-timeout needs positive milliseconds";
    o.node.tick_timeout_ms = static_cast<int>(ms);
    return "";
  }
  return "unknown argument '" + a + "'";
}

// Parses argv into `o`: 0, or 2 after printing the usage error.
int parse(std::span<char* const> args, Options& o) {
  static const std::string kValued =
      " --world --seed --door-width --duration --period --record-period --script --record --trace --daemon --name --key"
      " --host --sync --command-timeout --tick-timeout ";
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string a = args[i];
    if (set_flag(a, o)) continue;
    const bool valued = kValued.find(" " + a + " ") != std::string::npos;
    const char* v = valued && i + 1 < args.size() ? args[++i] : nullptr;
    if (const std::string why = set_value(a, v, o); !why.empty()) return usage_error(why);
  }
  return 0;
}

// A run without --serve: the world stepped here, driven by a script or by the scripted door opening.
class LocalRun {
 public:
  // Builds the world (and its visualizer, recorder) for `script` (none: the door opening): throws what cannot be built.
  LocalRun(const Options& o, const dca::sim::WorldConfig& config, std::optional<dca::sim::Script> script)
      : o_(o), config_(config), script_(std::move(script)), world_(config) {
    if (o.visualize) {
      std::string why;
      if (!world_.start_visualizer(&why))
        std::fprintf(stderr, "dca sim: --visualize: %s; running without it\n", why.c_str());
    }
    if (!o.record.empty()) recorder_.emplace(o.record);
  }

  // Runs until the end time (or half a second after the door opening ends) and prints the summary: the exit code.
  int run() {
    double end = o_.duration;
    if (end < 0) end = script_ && script_->end_time() >= 0 ? script_->end_time() : 120.0;
    std::printf("dca sim: door world, seed %llu, door %.3f m wide, robot at (%.3f, %.3f, %.1f deg), period %g s%s\n",
                static_cast<unsigned long long>(o_.seed), config_.door.width, config_.base_start.x,
                config_.base_start.y, config_.base_start.yaw * 180 / M_PI, config_.period,
                o_.realtime ? ", real time" : ", lock-step");
    std::fflush(stdout);
    const auto wall0 = std::chrono::steady_clock::now();
    step_until(end, wall0);
    return report(std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count());
  }

 private:
  // Steps the world until `end` (simulated s), recording and pacing as asked.
  void step_until(double end, std::chrono::steady_clock::time_point wall0) {
    const int record_every = std::max(1, static_cast<int>(std::lround(o_.record_period / config_.period)));
    if (recorder_) recorder_->record(world_.sensors(), -1);
    while (world_.time() < end - 1e-9) {
      if (script_ && !script_->advance(world_.time(), commands_)) break;
      if ((!script_ || script_->door_mode()) && !drive_door()) break;
      world_.set_commands(commands_);
      world_.step();
      ++steps_;
      if (recorder_ && steps_ % record_every == 0)
        recorder_->record(world_.sensors(), door_active_ ? static_cast<int>(phase_) : -1);
      if (o_.realtime)
        std::this_thread::sleep_until(wall0 + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                                  std::chrono::duration<double>(world_.time())));
    }
  }

  // One step of the scripted door opening, printing each phase as it starts: false when the run should end.
  bool drive_door() {
    if (!door_active_) {
      door_active_ = true;
      std::printf("%9.3f s  drive\n", world_.time());
    }
    commands_ = door_.update(world_);
    if (door_.phase() != phase_) {
      phase_ = door_.phase();
      if (phase_ == dca::sim::DoorPhase::failed)
        std::printf("%9.3f s  failed: %s\n", world_.time(), door_.failure().c_str());
      else
        std::printf("%9.3f s  %s\n", world_.time(), dca::sim::to_string(phase_));
      std::fflush(stdout);
      if (phase_ == dca::sim::DoorPhase::done || phase_ == dca::sim::DoorPhase::failed) done_at_ = world_.time();
    }
    return !(done_at_ >= 0 && o_.duration < 0 && world_.time() >= done_at_ + 0.5);
  }

  // Closes the recording and prints the summary (`door opened to ...`, the phases' start times): the exit code.
  int report(double wall) {
    std::string error;
    if (recorder_ && !recorder_->close(&error)) {
      std::fprintf(stderr, "dca sim: %s\n", error.c_str());
      return 1;
    }
    std::printf("door opened to %.1f deg\n", world_.sensors().door_angle * 180 / M_PI);
    std::printf("simulated %.3f s in %.3f s wall (%.1fx real time), %ld steps\n", world_.time(), wall,
                wall > 0 ? world_.time() / wall : 0.0, steps_);
    if (door_active_) {
      std::printf("steps:");
      for (int p = 0; p <= static_cast<int>(dca::sim::DoorPhase::done); ++p)
        if (door_.phase_start(static_cast<dca::sim::DoorPhase>(p)) >= 0)
          std::printf(" %s@%.3f", dca::sim::to_string(static_cast<dca::sim::DoorPhase>(p)),
                      door_.phase_start(static_cast<dca::sim::DoorPhase>(p)));
      std::printf("\n");
    }
    if (recorder_) std::printf("recorded %s\n", recorder_->summary().c_str());
    if (door_active_ && door_.phase() == dca::sim::DoorPhase::failed) {
      std::fprintf(stderr, "dca sim: the scripted door opening failed: %s\n", door_.failure().c_str());
      return 1;
    }
    return 0;
  }

  const Options& o_;
  const dca::sim::WorldConfig& config_;
  std::optional<dca::sim::Script> script_;
  dca::sim::World world_;
  std::optional<dca::sim::Recorder> recorder_;
  dca::sim::ScriptedDoorOpening door_;
  dca::sim::Commands commands_;
  dca::sim::DoorPhase phase_ = dca::sim::DoorPhase::drive;
  bool door_active_ = false;
  double done_at_ = -1;
  long steps_ = 0;
};

// --world ROBOT.urdf: the generic URDF world (app/sim_robot.h).
int robot_world(const Options& o) {
  if (!o.script.empty() || o.jammed || o.door_width > 0 || o.print_urdf || o.visualize)
    return usage_error("--script, --jammed, --door-width, --print-door-urdf and --visualize are the door's");
  dca::app::RobotSimOptions r;
  r.world = o.world;
  r.serve = o.serve, r.go = o.go, r.realtime = o.realtime;
  r.daemon = o.daemon, r.name = o.name, r.key = o.key, r.host = o.host, r.trace = o.node.trace;
  r.record = o.record, r.record_period = o.record_period;
  r.period = o.period, r.duration = o.duration, r.sync_period = o.node.sync_period;
  r.tick_timeout_ms = o.node.tick_timeout_ms;
  return dca::app::sim_robot(r);
}

int cmd_sim(std::span<char* const> args) {
  Options o;
  if (const int code = parse(args, o); code != 0) return code;
  if (!o.world.empty()) return robot_world(o);
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
    return LocalRun(o, config, std::move(script)).run();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dca sim: %s\n", e.what());
    return 1;
  }
}

// The signals of world `spec`, for dca check's device ports (bindings/core.h): those `dca sim --serve --world
// SPEC` hosts as ports. The door's are sim/world.h's; a URDF world's come from its file (app/sim_robot.h).
bool world_signals(const std::string& spec, dca::bindings::WorldSignals* out, std::string* error) {
  if (spec == "door") {
    for (const auto& x : dca::sim::kSensorSignals) out->outputs.push_back(dca::vector_port(x.name, x.size, x.units));
    for (const auto& x : dca::sim::kCommandSignals) out->inputs.push_back(dca::vector_port(x.name, x.size, x.units));
    return true;
  }
  if (!dca::app::is_robot_world(spec)) {
    *error = "world '" + spec + "': a world is door, ROBOT.urdf or mock:ROBOT.urdf[?lag=S&dead=J,...]";
    return false;
  }
  return dca::app::robot_world_signals(spec, &out->outputs, &out->inputs, error);
}

[[maybe_unused]] const bool kWorldSignalsRegistered = [] {
  dca::bindings::set_world_signals(&world_signals);
  return true;
}();

}  // namespace

DCA_SUBCOMMAND("sim", "run the simulated door world (Simbody) in lock-step or real time", kUsage, cmd_sim);
