// The TimerServer's cost per fired timer as a node holds more leaves (BENCHMARKS.md format): N aligned periodic
// timers of 10 ms on a simulated clock (what a shared node of N leaves runs), advanced round by round, beside the
// floor measured in the same run: the same N callables called in a plain loop. Alternated A B A B, N = 100, 1000.
//   RESULT bench=timer_rounds variant=<N>timers n=<rounds> p50_us=<per round> ... per_timer_ns=<p50 / N>
//   RESULT bench=raw_calls variant=<N>calls ...                                   per_timer_ns=...
// The goal (host/timers.h, the heap of due timers): per_timer_ns flat from 100 to 1,000 timers.
// Usage: bench_timer_scale [ROUNDS]   (default 2000)
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <string>
#include <vector>

#include "host/loop.h"  // before any other Asio header
#include "host/timers.h"
#include "tests/bench/bench_util.h"

using Clock = std::chrono::steady_clock;

namespace {

volatile std::uint64_t sink = 0;

double us_since(Clock::time_point t0) { return std::chrono::duration<double, std::micro>(Clock::now() - t0).count(); }

void print(const char* bench, const std::string& variant, std::vector<double>& us, std::size_t n) {
  std::sort(us.begin(), us.end());
  char extra[48];
  std::snprintf(extra, sizeof extra, " per_timer_ns=%.1f", dca::bench::quantile(us, 0.5) * 1000 / static_cast<double>(n));
  dca::bench::result(bench, variant, us, extra, 2);
}

// Wall time of each round of `rounds` 10 ms rounds over n aligned periodic timers.
std::vector<double> timer_rounds(std::size_t n, int rounds) {
  boost::asio::io_context io;
  dca::TimerServer s(io, dca::ClockKind::Simulated);
  s.set_aligned(true);
  constexpr dca::Nanos kPeriod = 10'000'000;
  for (std::size_t i = 0; i < n; ++i) s.every(kPeriod, [i] { sink = sink + i; }, "leaf" + std::to_string(i));
  std::vector<double> us;
  us.reserve(static_cast<std::size_t>(rounds));
  dca::Nanos t = 0;
  for (int r = 0; r < rounds; ++r) {
    t += kPeriod;
    const auto t0 = Clock::now();
    const auto fired = s.advance_to(t);
    us.push_back(us_since(t0));
    if (fired != n) std::fprintf(stderr, "round %d: %zu of %zu timers fired\n", r, fired, n);
  }
  return us;
}

// The floor: the same callables, called in a loop.
std::vector<double> raw_calls(std::size_t n, int rounds) {
  std::vector<std::function<void()>> fns;
  for (std::size_t i = 0; i < n; ++i) fns.emplace_back([i] { sink = sink + i; });
  std::vector<double> us;
  us.reserve(static_cast<std::size_t>(rounds));
  for (int r = 0; r < rounds; ++r) {
    const auto t0 = Clock::now();
    for (auto& f : fns) f();
    us.push_back(us_since(t0));
  }
  return us;
}

}  // namespace

int main(int argc, char** argv) {
  const int rounds = argc > 1 ? std::atoi(argv[1]) : 2000;
  for (int rep = 0; rep < 2; ++rep)
    for (const std::size_t n : {std::size_t{100}, std::size_t{1000}}) {
      auto a = timer_rounds(n, rounds);
      print("timer_rounds", std::to_string(n) + "timers", a, n);
      auto b = raw_calls(n, rounds);
      print("raw_calls", std::to_string(n) + "calls", b, n);
    }
  return 0;
}
