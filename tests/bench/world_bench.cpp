// Real-time factor of the simulated door world at 1 kHz in lock-step (target: >= 20x on a 2-core machine), and
// through its device layer against World directly (the door world's move onto the generic layer: no slower),
// beside two baselines measured in the same run: a one-body Simbody pendulum stepped the same number of times
// with the same integrator settings, and an empty loop of the same length. Variants alternate (A B A B).
// RESULT lines on stdout (BENCHMARKS.md); per-step latencies in microseconds; rtf = simulated / wall time.
#include <algorithm>
#include <chrono>
#include <ctime>
#include <cstdio>
#include <string>
#include <vector>

#include "worlds/door/door_script.h"
#include "worlds/door/door_world.h"
#include "sim/simbody_check.h"
#include "worlds/door/world.h"
#include "tests/bench/bench_util.h"

namespace {

using Clock = std::chrono::steady_clock;

double cpu_seconds() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

// rtf: simulated time over wall time (the sum of the steps); rtf_p50: the period over the median step (what
// an idle machine gives); rtf_cpu: simulated time over this thread's CPU time (preemption excluded).
void report(const std::string& bench, const std::string& variant, std::vector<double> us, double period,
            double cpu) {
  if (us.empty()) return;
  std::sort(us.begin(), us.end());
  double total = 0;
  for (double u : us) total += u;
  const double simulated = period * static_cast<double>(us.size());
  char extra[128];
  std::snprintf(extra, sizeof extra, " rtf=%.2f rtf_p50=%.2f rtf_cpu=%.2f", simulated * 1e6 / total,
                period * 1e6 / dca::bench::quantile(us, 0.5), simulated / cpu);
  dca::bench::result(bench, variant, us, extra, 2);
}

template <typename F>
void measure(const std::string& variant, F&& f) {
  const double c0 = cpu_seconds();
  std::vector<double> us = f();
  report("world_rtf", variant, std::move(us), 1e-3, cpu_seconds() - c0);
}

// The full world, arm held still and base parked: commands constant.
std::vector<double> world_steady(int n) {
  dca::sim::World w(dca::sim::door_world());
  std::vector<double> us;
  us.reserve(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) {
    const auto t0 = Clock::now();
    w.step();
    us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
  }
  return us;
}

// The full world with new commands every tick, as when controllers stream velocities.
std::vector<double> world_new_commands(int n) {
  dca::sim::World w(dca::sim::door_world());
  std::vector<double> us;
  us.reserve(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) {
    dca::sim::Commands c;
    const double s = (i / 500) % 2 ? 1 : -1;
    c.arm_qd = {0.05 * s, 0.02 * s, -0.03 * s, 0.1 * s, 0.05 * s, 0.1 * s};
    c.base_vel = {0.05 * s + 1e-6 * (i % 7), 0, 0};
    const auto t0 = Clock::now();
    w.set_commands(c);
    w.step();
    us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
  }
  return us;
}

// The whole scripted door opening (contact, grasp constraint, door motion), script cost excluded.
std::vector<double> world_scripted(double* door_deg) {
  dca::sim::World w(dca::sim::door_world());
  dca::sim::ScriptedDoorOpening script;
  std::vector<double> us;
  while (w.time() < 60 && script.phase() != dca::sim::DoorPhase::done &&
         script.phase() != dca::sim::DoorPhase::failed) {
    const dca::sim::Commands c = script.update(w);
    const auto t0 = Clock::now();
    w.set_commands(c);
    w.step();
    us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
  }
  *door_deg = w.sensors().door_angle * 180 / 3.141592653589793;
  return us;
}

// The same streamed commands through the door world's device layer (worlds/door/door_world.h), as the world
// process runs it since the door moved onto it: the three command inputs handed in by index, the step with the
// watchdog, and the eleven sensor outputs read out, every tick. Beside world_new_commands plus the same sensor
// read-out from World directly (what the door's own node did before the move).
std::vector<double> device_new_commands(int n, bool device_layer) {
  dca::sim::DoorDeviceWorld d(dca::sim::door_world(), 0.05);
  dca::sim::World& w = d.world();
  std::vector<double> us, out(8);
  us.reserve(static_cast<size_t>(n));
  volatile double sink = 0;
  for (int i = 0; i < n; ++i) {
    const double s = (i / 500) % 2 ? 1 : -1;
    const double arm[6] = {0.05 * s, 0.02 * s, -0.03 * s, 0.1 * s, 0.05 * s, 0.1 * s};
    const double base[3] = {0.05 * s + 1e-6 * (i % 7), 0, 0}, grip = 0;
    const auto t0 = Clock::now();
    if (device_layer) {
      d.command(0, base, 3), d.command(1, arm, 6), d.command(2, &grip, 1);
      d.step();
      for (std::size_t k = 0; k < d.sensors().size(); ++k) {
        d.sensor(k, out.data());
        sink = sink + out[0];
      }
    } else {
      dca::sim::Commands c;
      std::copy(arm, arm + 6, c.arm_qd.begin());
      std::copy(base, base + 3, c.base_vel.begin());
      w.set_commands(c);
      w.step();
      const dca::sim::Sensors& x = w.sensors();
      sink = sink + x.arm_q[0] + x.arm_qd[0] + x.base_pose.x + x.base_vel[0] + x.wrench[0] + x.laser_range +
             x.camera_handle[0] + x.door_angle + x.handle_angle + x.gripper_width;
    }
    us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
  }
  return us;
}

// Baseline: the one-body pendulum, the same number of 1 ms steps with Simbody's SemiExplicitEulerIntegrator
// (its total time only, spread evenly over the steps).
std::vector<double> pendulum(int n) {
  const auto t0 = Clock::now();
  volatile double q = dca::sim::pendulum_angle_after(0.1, 1e-3, n);
  (void)q;
  const double per = std::chrono::duration<double, std::micro>(Clock::now() - t0).count() / n;
  return std::vector<double>(static_cast<size_t>(n), per);
}

// Baseline: an empty loop of n iterations with the same clock reads.
std::vector<double> empty_loop(int n) {
  std::vector<double> us;
  us.reserve(static_cast<size_t>(n));
  volatile double sink = 0;
  for (int i = 0; i < n; ++i) {
    const auto t0 = Clock::now();
    sink = sink + 1;
    us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
  }
  return us;
}

}  // namespace

int main() {
  const int n = 10000;  // 10 simulated seconds
  for (int round = 0; round < 2; ++round) {
    std::fprintf(stderr, "round %d\n", round + 1);
    measure("door_1kHz_steady", [&] { return world_steady(n); });
    measure("pendulum_1body_1kHz_simbody_integrator", [&] { return pendulum(n); });
    measure("door_1kHz_new_cmd_each_tick", [&] { return world_new_commands(n); });
    measure("empty_loop", [&] { return empty_loop(n); });
    measure("door_1kHz_new_cmd_world_direct", [&] { return device_new_commands(n, false); });
    measure("door_1kHz_new_cmd_device_layer", [&] { return device_new_commands(n, true); });
    double door = 0;
    size_t steps = 0;
    measure("door_1kHz_scripted_opening", [&] {
      auto us = world_scripted(&door);
      steps = us.size();
      return us;
    });
    std::fprintf(stderr, "scripted opening: door reached %.1f deg in %.3f simulated s\n", door,
                 static_cast<double>(steps) * 1e-3);
  }
  return 0;
}
