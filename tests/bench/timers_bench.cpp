// Timer lateness (BENCHMARKS.md format): a 1 kHz periodic timer of the TimerServer (timerfd on the io_context,
// as controllers use it) beside a raw clock_nanosleep(TIMER_ABSTIME) loop, both with 1 ns timer slack,
// alternated A B A B. Lateness = when the callback starts - its deadline.
// Usage: bench_timers [TICKS_PER_ROUND]   (default 2000, i.e. 2 s per round; 2 rounds of each)
// host/loop.h comes first: it includes Asio with GCC 12's false positives silenced (the one place).
#include "host/loop.h"

#include <time.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "host/timers.h"
#include "tests/bench/bench_util.h"

namespace {

constexpr dca::Nanos kPeriod = 1'000'000;

void print(const char* bench, std::vector<double>& v, const std::string& extra = "") {
  dca::bench::result(bench, "1kHz", v, extra, 2);
}

void dca_round(int ticks, std::vector<double>& out, dca::TimerStats& stats) {
  boost::asio::io_context io;
  dca::TimerServer ts(io, dca::ClockKind::Wall);
  const dca::Nanos first = ts.now() + kPeriod;  // absolute deadlines from here
  int k = 0;
  dca::TimerServer::Id id = 0;
  id = ts.every(kPeriod, [&] {
    const dca::Nanos late = dca::monotonic_now() - ts.current_deadline();
    out.push_back(static_cast<double>(late) / 1000.0);
    if (++k == ticks) {
      ts.cancel(id);
      io.stop();
    }
  }, "bench", first);
  io.run();
  stats = *ts.stats(id);
}

void raw_round(int ticks, std::vector<double>& out) {
  dca::minimise_timer_slack();
  timespec next{};
  clock_gettime(CLOCK_MONOTONIC, &next);
  for (int k = 0; k < ticks; ++k) {
    next.tv_nsec += kPeriod;
    if (next.tv_nsec >= 1'000'000'000) {
      next.tv_nsec -= 1'000'000'000;
      ++next.tv_sec;
    }
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next, nullptr) != 0) {
    }
    const dca::Nanos deadline = static_cast<dca::Nanos>(next.tv_sec) * 1'000'000'000 + next.tv_nsec;
    out.push_back(static_cast<double>(dca::monotonic_now() - deadline) / 1000.0);
  }
}

}  // namespace

int main(int argc, char** argv) {
  const int ticks = argc > 1 ? std::max(100, std::atoi(argv[1])) : 2000;
  std::vector<double> d, r;
  dca::TimerStats s;
  for (int round = 0; round < 2; ++round) {
    std::fprintf(stderr, "timer round %d\n", round + 1);
    dca_round(ticks, d, s);
    raw_round(ticks, r);
  }
  print("dca_timer_lateness", d,
        " missed=" + std::to_string(s.missed) + " server_p99_us=" + std::to_string(s.p99_us));
  print("raw_clock_nanosleep_lateness", r);
  return 0;
}
