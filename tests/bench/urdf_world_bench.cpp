// The generic URDF world's step rate for the UR10 (worlds/ur10/ur10.urdf, Simbody, 1 kHz) beside a bare Simbody
// integration of the same model in the same run (sim/urdf/bare.h: gravity and the loader's stops only, the same
// semi-explicit Euler step; no ports, no servos, no safety layer). Goal: the world at >= 0.9 of the bare rate.
// The world gets an elbow position command every 10 steps (a controller at 100 Hz) through the safety layer; the
// mock hardware's rate is printed too. Variants alternate (A B A B). RESULT lines on stdout (BENCHMARKS.md): per
// step in microseconds; steps_per_s = steps over the sum of the steps (wall); ratio_to_bare = that over the bare
// rate of the same round; ratio_p50 = the bare median step over this one (what an idle machine gives);
// ratio_cpu = the same from this thread's CPU time (preemption excluded). The ratios say the world's rate as a
// fraction of the bare integration's: the goal is >= 0.9.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <string>
#include <vector>

#include "sim/urdf/bare.h"
#include "sim/urdf/joint_world.h"
#include "tests/bench/bench_util.h"

namespace {

using Clock = std::chrono::steady_clock;
const std::string kUr10 = std::string(DCA_SOURCE_DIR) + "/worlds/ur10/ur10.urdf";

double cpu_seconds() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

// A variant's steps (us each) and the thread's CPU time over them.
struct Run {
  std::vector<double> us;
  double cpu = 0;
};

double rate(const std::vector<double>& us) {
  double total = 0;
  for (const double u : us) total += u;
  return total > 0 ? 1e6 * static_cast<double>(us.size()) / total : 0;
}

template <typename Step>
Run timed(int n, Step&& step) {
  Run r;
  r.us.reserve(static_cast<size_t>(n));
  const double c0 = cpu_seconds();
  for (int i = 0; i < n; ++i) {
    const auto t0 = Clock::now();
    step(i);
    r.us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
  }
  r.cpu = cpu_seconds() - c0;
  return r;
}

Run bare(int n) {
  dca::sim::BareUrdf b(kUr10, 1e-3);
  Run r = timed(n, [&](int) { b.step(); });
  volatile double q = b.q0();
  (void)q;
  return r;
}

Run world(const std::string& spec, int n) {
  auto w = dca::sim::make_robot_world(spec, 1e-3);
  const std::size_t elbow = dca::sim::signal_index(w->commands(), "joint.elbow_joint.position_command");
  return timed(n, [&](int i) {
    if (i % 10 == 0) {
      const double target = (i / 2000) % 2 ? 1.0 : 1.5;
      w->command(elbow, &target, 1);
    }
    w->step();
  });
}

double median(std::vector<double> us) {
  std::sort(us.begin(), us.end());
  return dca::bench::quantile(us, 0.5);
}

void report(const std::string& variant, Run run, const Run& base) {
  const double r = rate(run.us), base_rate = rate(base.us);
  char extra[160];
  std::snprintf(extra, sizeof extra, " steps_per_s=%.0f ratio_to_bare=%.3f ratio_p50=%.3f ratio_cpu=%.3f", r,
                base_rate > 0 ? r / base_rate : 0.0, median(base.us) / median(run.us), base.cpu / run.cpu);
  dca::bench::result("urdf_world", variant, run.us, extra, 2);
}

}  // namespace

int main() {
  const int n = 20000;  // 20 simulated seconds
  for (int round = 0; round < 2; ++round) {
    std::fprintf(stderr, "round %d\n", round + 1);
    const Run base = bare(n);
    report("ur10_bare_simbody_1kHz", base, base);
    report("ur10_world_1kHz", world(kUr10, n), base);
    report("ur10_mock_1kHz", world("mock:" + kUr10, n), base);
  }
  return 0;
}
