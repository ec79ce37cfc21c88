// The in-process closed-loop door harness (worlds/door/tests/door_harness.h) as a benchmark: the door task of
// door_open.dca in one process, one TimerServer, no sockets and no supervisors: the baseline that
// tests/bench/door_bench.lua measures the supervised system against, on the same seed, in the same run.
//
//   bench_door_harness [SEED] [MOTION_PERIOD_S]   (MotionControl's period, default 0.01)
//   RESULT bench=door_harness variant=seedN_motionP n=<10 ms periods> p50_us=.. p99_us=.. p999_us=.. max_us=.. rtf=..
//          wall_s=.. sim_s=.. door_deg=..
// The latency fields are the mean wall time per 10 ms of simulated time (the harness has no rounds to time).
#include <chrono>
#include <cstdio>
#include <cstdlib>

#include "worlds/door/world.h"
#include "worlds/door/tests/door_harness.h"

int main(int argc, char** argv) {
  const int seed = argc > 1 ? std::atoi(argv[1]) : 0;
  const double motion = argc > 2 ? std::atof(argv[2]) : 0.01;
  dca::testing::DoorHarness h(dca::sim::door_world(static_cast<std::uint64_t>(seed)), motion);
  const auto t0 = std::chrono::steady_clock::now();
  const auto r = h.run_task(60.0);
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (!r.failure.empty()) std::fprintf(stderr, "door harness, seed %d: %s\n", seed, r.failure.c_str());
  const double us = r.time > 0 ? wall / r.time * 1e4 : 0;
  std::printf("RESULT bench=door_harness variant=seed%d_motion%gms n=%ld p50_us=%.1f p99_us=%.1f p999_us=%.1f max_us=%.1f "
              "rtf=%.2f wall_s=%.3f sim_s=%.3f door_deg=%.1f\n",
              seed, motion * 1e3, static_cast<long>(r.time / 0.01), us, us, us, us, r.time / wall, wall, r.time, r.door_angle);
  // the steps' simulated times, as `dca run`'s summary lists them (stderr: not a RESULT line)
  for (std::size_t i = 0; i < r.step_start.size(); ++i)
    std::fprintf(stderr, "  %8.3f - %8.3f  %s (door at %.17g rad)\n", r.step_start[i],
                 i < r.step_end.size() ? r.step_end[i] : -1.0, h.steps()[i].name.c_str(),
                 i < r.step_end_door_angle.size() ? r.step_end_door_angle[i] : 0.0);
  return r.failure.empty() ? 0 : 1;
}
