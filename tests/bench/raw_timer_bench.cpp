// The baseline of a control period (BENCHMARKS.md format): a plain periodic timer in a plain process, no dca.
// A Boost.Asio steady_timer on its own io_context, re-armed at absolute deadlines (previous deadline + period,
// no drift), with the thread's timer slack at 1 ns (as dca's timers and the paced world have). The figure is
// the wall-clock interval between consecutive callbacks: the period such a loop achieves on this machine,
// what MotionControl's achieved period is judged against (tests/bench/motion_period_bench.lua runs it between
// its door runs, A B A B).
//   RESULT bench=raw_timer_baseline variant=<period>ms n=.. p50_us=.. p99_us=.. p999_us=.. max_us=.. min_us=..
// Usage: bench_raw_timer [TICKS] [PERIOD_MS]   (default 5000 ticks of 1 ms)
// host/loop.h comes first: it includes Asio with GCC 12's false positives silenced (the one place).
#include "host/loop.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <vector>

#include "host/timers.h"
#include "tests/bench/bench_util.h"

int main(int argc, char** argv) {
  const int ticks = argc > 1 ? std::max(100, std::atoi(argv[1])) : 5000;
  const double period_ms = argc > 2 ? std::max(0.01, std::atof(argv[2])) : 1.0;
  const auto period = std::chrono::nanoseconds(static_cast<std::int64_t>(period_ms * 1e6));
  dca::minimise_timer_slack();
  boost::asio::io_context io;
  boost::asio::steady_timer timer(io);
  std::vector<double> iv;
  iv.reserve(static_cast<std::size_t>(ticks));
  auto deadline = std::chrono::steady_clock::now() + period;
  dca::Nanos last = -1;
  int k = 0;
  std::function<void(const boost::system::error_code&)> tick = [&](const boost::system::error_code& ec) {
    if (ec) return;
    const dca::Nanos now = dca::monotonic_now();
    if (last >= 0) iv.push_back(static_cast<double>(now - last) / 1000.0);
    last = now;
    if (++k > ticks) return;  // ticks intervals, ticks + 1 callbacks
    deadline += period;
    timer.expires_at(deadline);
    timer.async_wait(tick);
  };
  timer.expires_at(deadline);
  timer.async_wait(tick);
  io.run();
  if (iv.empty()) return 1;
  char variant[32], extra[32];
  std::snprintf(variant, sizeof variant, "%gms", period_ms);
  std::snprintf(extra, sizeof extra, " min_us=%.1f", *std::min_element(iv.begin(), iv.end()));
  dca::bench::result("raw_timer_baseline", variant, iv, extra);
  return 0;
}
