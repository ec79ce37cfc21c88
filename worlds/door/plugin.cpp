// The door world's plug-in (sim/world_plugin.h, docs/worlds.md): its options, the world process's DoorDeviceWorld,
// and `dca sim --world door` run here, driven by an open-loop script or the built-in scripted door opening.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>

#include "sim/world_plugin.h"
#include "worlds/door/door_script.h"
#include "worlds/door/door_world.h"
#include "worlds/door/recording.h"
#include "worlds/door/script.h"

namespace dca::sim {
namespace {

using Kind = WorldOption::Kind;

// The world `setup` describes (its visualizer started when asked).
WorldConfig config_of(const WorldSetup& setup) {
  WorldConfig config = door_world(setup.seed, setup.options.number("door_width", 0));
  config.period = setup.period;
  if (setup.options.flag("jammed")) config.door.handle_jammed = config.door.latch_jammed = true;
  return config;
}

void start_visualizer(World& world) {
  std::string why;
  if (!world.start_visualizer(&why)) std::fprintf(stderr, "dca sim: visualize: %s; running without it\n", why.c_str());
}

std::unique_ptr<DeviceWorld> make(const WorldSetup& setup) {
  if (setup.options.has("script"))
    throw std::invalid_argument("world option script is for `dca sim` run here: served, the nodes drive the robot");
  auto w = std::make_unique<DoorDeviceWorld>(config_of(setup), setup.options.number("command_timeout", 0.05));
  if (setup.options.flag("visualize")) start_visualizer(w->world());
  return w;
}

void signals(const WorldSetup&, std::vector<DeviceSignal>* sensors, std::vector<DeviceSignal>* commands) {
  door_signals(sensors, commands);
}

// The world stepped here, driven by a script or by the scripted door opening.
class DoorRun {
 public:
  // Builds the world (and its visualizer, recorder) for `script` (none: the door opening): throws what cannot be built.
  DoorRun(const WorldSetup& setup, const LocalRun& o, std::optional<Script> script)
      : setup_(setup), o_(o), config_(config_of(setup)), script_(std::move(script)), world_(config_) {
    if (setup.options.flag("visualize")) start_visualizer(world_);
    if (!o.record.empty()) {
      recording_.emplace(o.record);
      recording_->recorder().configure(o.recording);
    }
  }

  // Runs until the end time (or half a second after the door opening ends) and prints the summary: the exit code.
  int run() {
    double end = o_.duration;
    if (end < 0) end = script_ && script_->end_time() >= 0 ? script_->end_time() : 120.0;
    std::printf("dca sim: door world, seed %llu, door %.3f m wide, robot at (%.3f, %.3f, %.1f deg), period %g s%s\n",
                static_cast<unsigned long long>(setup_.seed), config_.door.width, config_.base_start.x,
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
    if (recording_) recording_->record(world_.sensors(), -1);
    while (world_.time() < end - 1e-9) {
      if (script_ && !script_->advance(world_.time(), commands_)) break;
      if ((!script_ || script_->door_mode()) && !drive_door()) break;
      world_.set_commands(commands_);
      world_.step();
      ++steps_;
      if (recording_ && steps_ % record_every == 0)
        recording_->record(world_.sensors(), door_active_ ? static_cast<int>(phase_) : -1);
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
      if (phase_ == DoorPhase::failed)
        std::printf("%9.3f s  failed: %s\n", world_.time(), door_.failure().c_str());
      else
        std::printf("%9.3f s  %s\n", world_.time(), to_string(phase_));
      std::fflush(stdout);
      if (phase_ == DoorPhase::done || phase_ == DoorPhase::failed) done_at_ = world_.time();
    }
    return !(done_at_ >= 0 && o_.duration < 0 && world_.time() >= done_at_ + 0.5);
  }

  // Closes the recording and prints the summary (`door opened to ...`, the phases' start times): the exit code.
  int report(double wall) {
    std::string error;
    if (recording_ && !recording_->recorder().close(&error)) {
      std::fprintf(stderr, "dca sim: %s\n", error.c_str());
      return 1;
    }
    std::printf("door opened to %.1f deg\n", world_.sensors().door_angle * 180 / M_PI);
    std::printf("simulated %.3f s in %.3f s wall (%.1fx real time), %ld steps\n", world_.time(), wall,
                wall > 0 ? world_.time() / wall : 0.0, steps_);
    if (door_active_) {
      std::printf("steps:");
      for (int p = 0; p <= static_cast<int>(DoorPhase::done); ++p)
        if (door_.phase_start(static_cast<DoorPhase>(p)) >= 0)
          std::printf(" %s@%.3f", to_string(static_cast<DoorPhase>(p)), door_.phase_start(static_cast<DoorPhase>(p)));
      std::printf("\n");
    }
    if (recording_) std::printf("recorded %s\n", recording_->recorder().summary().c_str());
    if (door_active_ && door_.phase() == DoorPhase::failed) {
      std::fprintf(stderr, "dca sim: the scripted door opening failed: %s\n", door_.failure().c_str());
      return 1;
    }
    return 0;
  }

  const WorldSetup& setup_;
  const LocalRun& o_;
  WorldConfig config_;
  std::optional<Script> script_;
  World world_;
  std::optional<DoorRecording> recording_;
  ScriptedDoorOpening door_;
  Commands commands_;
  DoorPhase phase_ = DoorPhase::drive;
  bool door_active_ = false;
  double done_at_ = -1;
  long steps_ = 0;
};

int run_local(const WorldSetup& setup, const LocalRun& o) {
  if (setup.options.flag("print_urdf")) {
    std::fputs(door_urdf(config_of(setup).door).c_str(), stdout);
    return 0;
  }
  try {
    std::optional<Script> script;
    std::string error;
    if (setup.options.has("script") && !Script::load(setup.options.text("script"), &script.emplace(), &error)) {
      std::fprintf(stderr, "dca sim: %s\n", error.c_str());
      return 1;
    }
    return DoorRun(setup, o, std::move(script)).run();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dca sim: %s\n", e.what());
    return 1;
  }
}

WorldPlugin plugin() {
  WorldPlugin p;
  p.name = "door";
  p.summary = "the paper's mobile manipulator and a door (worlds/door/models), Simbody";
  p.options = {
      {"door_width", Kind::number, "the door's width in metres (overrides the seed's)", 0.5, 1.5},
      {"jammed", Kind::flag, "a fault: the handle is seized and the latch never releases", 0, 0},
      {"command_timeout", Kind::number, "s: base and arm commands older than this count as zero", 0.001, 10},
      {"visualize", Kind::flag, "show the world in Simbody's 3-D visualizer where a display exists", 0, 0},
      {"script", Kind::text, "run here only: open-loop commands, `TIME WORD ARGS` per line (worlds/door/script.h)", 0, 0},
      {"print_urdf", Kind::flag, "run here only: print the door's URDF for the chosen width and exit", 0, 0},
  };
  p.make = make;
  p.signals = signals;
  p.run_local = run_local;
  return p;
}

const WorldRegistration kDoor{plugin()};

}  // namespace
}  // namespace dca::sim
