// TimerServer: wall-clock timers on a timerfd, simulated time advanced by a master, lateness statistics.
#include "host/timers.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include <boost/asio/io_context.hpp>

namespace {

using namespace std::chrono_literals;

bool run_until(boost::asio::io_context& io, const std::function<bool()>& pred, std::chrono::milliseconds timeout = 5s) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (!pred()) {
    if (std::chrono::steady_clock::now() >= deadline) return false;
    io.restart();
    io.run_one_for(10ms);
  }
  return true;
}

constexpr dca::Nanos kMs = 1'000'000;

class TimersTest : public ::testing::Test {
 protected:
  boost::asio::io_context io;
};

TEST_F(TimersTest, SecondsConvert) {
  EXPECT_EQ(dca::from_seconds(0.001), kMs);
  EXPECT_DOUBLE_EQ(dca::to_seconds(1'500'000'000), 1.5);
}

// Times past 2^63 ns (about 292 years) saturate to "never" instead of overflowing into the past: a Deadline of
// 1e10 s aborted at once, a Timer of 1e10 s ended after 0.12 s.
TEST_F(TimersTest, LongTimesSaturateToNeverAndNeverFire) {
  EXPECT_EQ(dca::from_seconds(1e10), dca::kNever);
  EXPECT_EQ(dca::from_seconds(1e300), dca::kNever);
  EXPECT_EQ(dca::from_seconds(std::numeric_limits<double>::infinity()), dca::kNever);
  EXPECT_EQ(dca::from_seconds(-std::numeric_limits<double>::infinity()), -dca::kNever);
  EXPECT_EQ(dca::from_seconds(std::numeric_limits<double>::quiet_NaN()), 0);
  EXPECT_EQ(dca::from_seconds(9e9), 9'000'000'000'000'000'000);
  dca::TimerServer ts(io, dca::ClockKind::Simulated);
  int fired = 0;
  ts.advance_to(5'000'000'000);
  ts.after(dca::from_seconds(1e10), [&] { ++fired; });
  ts.every(dca::from_seconds(1e300), [&] { ++fired; });
  EXPECT_EQ(ts.next_deadline(), dca::kNever);
  EXPECT_EQ(ts.advance_to(9'000'000'000'000'000'000), 0u);
  EXPECT_EQ(fired, 0);
  // near the end of time a period still lands at kNever, not in the past
  dca::TimerServer late(io, dca::ClockKind::Simulated);
  late.advance_to(dca::kNever - 10);
  late.every(100, [&] { ++fired; });
  EXPECT_EQ(late.next_deadline(), dca::kNever);
  // the wall clock arms nothing for a timer due never
  dca::TimerServer wall(io, dca::ClockKind::Wall);
  wall.after(dca::kNever, [&] { ++fired; });
  io.restart();
  io.poll();
  EXPECT_EQ(fired, 0);
}

TEST_F(TimersTest, HistogramQuantilesAndMax) {
  dca::LatenessHistogram h;
  for (int i = 0; i < 99; ++i) h.record(10'500);  // 10.5 µs -> bucket [10, 11) µs
  h.record(5'000'000);                             // 5 ms
  EXPECT_EQ(h.count(), 100u);
  EXPECT_EQ(h.quantile(0.5), 11'000);
  EXPECT_EQ(h.quantile(0.99), 11'000);
  EXPECT_EQ(h.quantile(1.0), 5'000'000);
  EXPECT_EQ(h.max(), 5'000'000);
  h.record(-5);  // early counts as on time
  EXPECT_EQ(h.count(), 101u);
}

TEST_F(TimersTest, SimulatedTimeStandsStillUntilAdvanced) {
  dca::TimerServer ts(io, dca::ClockKind::Simulated);
  int fired = 0;
  ts.after(5 * kMs, [&] { ++fired; });
  io.restart();
  io.poll();
  EXPECT_EQ(fired, 0);
  EXPECT_EQ(ts.now(), 0);
  EXPECT_EQ(ts.next_deadline(), 5 * kMs);
  EXPECT_EQ(ts.advance_to(4 * kMs), 0u);
  EXPECT_EQ(ts.advance_to(5 * kMs), 1u);
  EXPECT_EQ(fired, 1);
  EXPECT_FALSE(ts.next_deadline());
  EXPECT_THROW(ts.advance_to(1 * kMs), std::logic_error);
}

TEST_F(TimersTest, AdvanceRunsDueTimersInDeadlineThenCreationOrder) {
  dca::TimerServer ts(io, dca::ClockKind::Simulated);
  std::vector<std::string> trace;
  auto rec = [&](std::string n) {
    return [&trace, &ts, n] {
      EXPECT_EQ(ts.current_deadline(), ts.now());
      trace.push_back(n + "@" + std::to_string(ts.now() / kMs));
    };
  };
  ts.every(2 * kMs, rec("b"), "b");
  ts.every(1 * kMs, rec("a"), "a");
  ts.every(3 * kMs, rec("c"), "c");
  EXPECT_EQ(ts.advance_to(6 * kMs), 11u);
  EXPECT_EQ(trace, (std::vector<std::string>{"a@1", "b@2", "a@2", "a@3", "c@3", "b@4", "a@4", "a@5", "b@6", "a@6",
                                             "c@6"}));
  EXPECT_EQ(ts.now(), 6 * kMs);
  EXPECT_EQ(ts.current_deadline(), -1);  // outside callbacks
  const auto s = ts.stats();
  ASSERT_EQ(s.size(), 3u);
  EXPECT_EQ(s[1].name, "a");
  EXPECT_EQ(s[1].count, 6u);
  EXPECT_EQ(s[1].max_us, 0.0);  // simulated time is never late
}

TEST_F(TimersTest, StepMovesToTheNextDeadline) {
  dca::TimerServer ts(io, dca::ClockKind::Simulated);
  int n = 0;
  ts.every(3 * kMs, [&] { ++n; });
  EXPECT_EQ(ts.step(), 1u);
  EXPECT_EQ(ts.now(), 3 * kMs);
  EXPECT_EQ(ts.step(), 1u);
  EXPECT_EQ(ts.now(), 6 * kMs);
  EXPECT_EQ(n, 2);
}

TEST_F(TimersTest, CancelFromInsideItsOwnCallback) {
  dca::TimerServer ts(io, dca::ClockKind::Simulated);
  int n = 0;
  dca::TimerServer::Id id = 0;
  id = ts.every(kMs, [&] {
    if (++n == 3) ts.cancel(id);
  });
  ts.advance_to(10 * kMs);
  EXPECT_EQ(n, 3);
  EXPECT_FALSE(ts.cancel(id));
  EXPECT_FALSE(ts.stats(id)->active);
}

TEST_F(TimersTest, CallbacksMayAddTimers) {
  dca::TimerServer ts(io, dca::ClockKind::Simulated);
  std::vector<int> order;
  ts.after(kMs, [&] {
    order.push_back(1);
    ts.after(kMs, [&] { order.push_back(2); });
  });
  ts.advance_to(5 * kMs);
  EXPECT_EQ(order, (std::vector<int>{1, 2}));
}

TEST_F(TimersTest, AdvanceOnTheWallClockIsRefused) {
  dca::TimerServer ts(io, dca::ClockKind::Wall);
  EXPECT_THROW(ts.advance_to(0), std::logic_error);
}

TEST_F(TimersTest, WallPeriodicTimerFiresAndRecordsLateness) {
  dca::TimerServer ts(io, dca::ClockKind::Wall);
  int n = 0;
  const auto start = ts.now();
  const auto id = ts.every(kMs, [&] { ++n; }, "tick");
  ASSERT_TRUE(run_until(io, [&] { return n >= 20; }));
  EXPECT_GE(ts.now() - start, 20 * kMs);  // absolute deadlines: never early
  const auto s = ts.stats(id);
  ASSERT_TRUE(s);
  EXPECT_EQ(s->name, "tick");
  EXPECT_EQ(s->count + 0, static_cast<std::uint64_t>(n));
  EXPECT_GE(s->max_us, s->p99_us);
  EXPECT_GE(s->p99_us, s->p50_us);
  ts.cancel(id);
  const int stopped_at = n;
  int later = 0;
  ts.after(3 * kMs, [&] { ++later; });
  ASSERT_TRUE(run_until(io, [&] { return later == 1; }));
  EXPECT_EQ(n, stopped_at);  // cancelled: no more ticks
}

// Driven (a node's real-time thread, host/node_rt.h): the timerfd stays disarmed; run_due() runs what is due by
// the wall clock, a late timer once (the periods that went by skipped and counted, not run in a burst), and
// on_ran tells each run's deadline, period and wall-clock start and end.
TEST_F(TimersTest, DrivenServerRunsOnlyInRunDueAndSkipsLatePeriods) {
  dca::TimerServer ts(io, dca::ClockKind::Wall);
  ts.set_driven();
  int n = 0;
  std::vector<std::pair<dca::Nanos, dca::Nanos>> ran;  // (deadline, start)
  ts.on_ran = [&](const std::string& name, dca::Nanos deadline, dca::Nanos period, dca::Nanos start, dca::Nanos end) {
    EXPECT_EQ(name, "tick");
    EXPECT_EQ(period, kMs);
    EXPECT_LE(start, end);
    ran.emplace_back(deadline, start);
  };
  const auto id = ts.every(kMs, [&] { ++n; }, "tick");
  const auto first = *ts.next_deadline();
  while (dca::monotonic_now() < first + kMs / 2) io.poll();  // (the clock, not a sleep: due, and the fd silent)
  EXPECT_EQ(n, 0);
  ASSERT_GE(ts.run_due(), 1u);
  EXPECT_EQ(ran[0].first, first);
  EXPECT_GE(ran[0].second, first);
  // ten more deadlines go by: run once (twice if this thread was preempted inside run_due), never ten times
  const auto next = *ts.next_deadline();
  const int before = n;
  while (dca::monotonic_now() < next + 10 * kMs) io.poll();
  const auto runs = ts.run_due();
  EXPECT_GE(runs, 1u);
  EXPECT_LE(runs, 2u);
  EXPECT_EQ(n, before + static_cast<int>(runs));
  EXPECT_GE(ts.stats(id)->missed, 8u);
  EXPECT_GT(*ts.next_deadline(), next + 10 * kMs);  // the next deadline ahead of the last run
  EXPECT_THROW(dca::TimerServer(io, dca::ClockKind::Simulated).set_driven(), std::logic_error);
}

TEST_F(TimersTest, WallOneShotFiresOnceNotBeforeItsDelay) {
  dca::TimerServer ts(io, dca::ClockKind::Wall);
  dca::Nanos at = 0;
  const auto start = ts.now();
  ts.after(2 * kMs, [&] { at = ts.now(); });
  ASSERT_TRUE(run_until(io, [&] { return at != 0; }));
  EXPECT_GE(at - start, 2 * kMs);
  EXPECT_FALSE(ts.next_deadline());
}

TEST_F(TimersTest, IntervalHistogramIsExactForEqualRecordsAndWithinItsBucketOtherwise) {
  dca::IntervalHistogram h;
  EXPECT_EQ(h.quantile(0.5), 0);
  EXPECT_EQ(h.min(), 0);
  for (int i = 0; i < 1000; ++i) h.record(kMs);
  EXPECT_EQ(h.count(), 1000u);
  EXPECT_EQ(h.quantile(0.5), kMs);
  EXPECT_EQ(h.quantile(0.99), kMs);
  EXPECT_EQ(h.quantile(0.999), kMs);
  EXPECT_EQ(h.min(), kMs);
  EXPECT_EQ(h.max(), kMs);
  EXPECT_DOUBLE_EQ(h.mean(), 1e6);
  // small values are exact; larger ones are reported at most one bucket (1/512 of the value) high
  dca::IntervalHistogram g;
  for (dca::Nanos v : {dca::Nanos{0}, dca::Nanos{1}, dca::Nanos{1023}}) {
    g = {};
    g.record(v);
    g.record(2 * v + 5'000'000);  // a larger max, so the quantile is not clamped to it
    EXPECT_EQ(g.quantile(0.5), v);
  }
  for (dca::Nanos v : {dca::Nanos{1024}, dca::Nanos{1'000'123}, dca::Nanos{10'000'000}, dca::Nanos{123'456'789'012}}) {
    g = {};
    g.record(v);
    g.record(2 * v + 5'000'000);
    EXPECT_GE(g.quantile(0.5), v);
    EXPECT_LE(g.quantile(0.5), v + v / 512) << v;
  }
  g = {};
  g.record(-7);  // negative: 0
  g.record(dca::Nanos{1} << 40);  // beyond the top bucket: counted, its max exact
  EXPECT_EQ(g.min(), 0);
  EXPECT_EQ(g.max(), dca::Nanos{1} << 40);
  EXPECT_EQ(g.quantile(1.0), dca::Nanos{1} << 40);
  // 99 intervals of 1 ms and one of 3 ms: p50 and p99 1 ms (the upper edge of its 1.024 µs bucket), p999 and
  // max 3 ms
  dca::IntervalHistogram m, other;
  for (int i = 0; i < 60; ++i) m.record(kMs);
  for (int i = 0; i < 39; ++i) other.record(kMs);
  other.record(3 * kMs);
  m.merge(other);
  EXPECT_EQ(m.count(), 100u);
  EXPECT_EQ(m.min(), kMs);
  EXPECT_GE(m.quantile(0.5), kMs);
  EXPECT_LT(m.quantile(0.5), kMs + 1024);
  EXPECT_EQ(m.quantile(0.99), m.quantile(0.5));
  EXPECT_EQ(m.quantile(0.999), 3 * kMs);
  EXPECT_EQ(m.max(), 3 * kMs);
  EXPECT_DOUBLE_EQ(m.mean(), 1.02e6);
}

TEST_F(TimersTest, PeriodicTimerAt1msOnASimulatedClockAchievesExactly1ms) {
  dca::TimerServer ts(io, dca::ClockKind::Simulated);
  ts.set_aligned(true);
  int n = 0;
  ts.every(kMs, [&] { ++n; }, "main.motion.redundancy");
  ts.after(5 * kMs, [] {}, "one-shot");  // one-shot timers have no period to measure
  for (int k = 1; k <= 100; ++k) ts.advance_to(k * kMs);  // as the master does, one tick at a time
  ASSERT_EQ(n, 100);
  const auto iv = ts.interval_stats();
  ASSERT_EQ(iv.size(), 1u);
  EXPECT_EQ(iv[0].name, "main.motion.redundancy");
  EXPECT_EQ(iv[0].period, kMs);
  EXPECT_EQ(iv[0].clock.n, 99u);  // 100 calls, 99 intervals between them
  EXPECT_DOUBLE_EQ(iv[0].clock.p50_us, 1000.0);
  EXPECT_DOUBLE_EQ(iv[0].clock.p99_us, 1000.0);
  EXPECT_DOUBLE_EQ(iv[0].clock.p999_us, 1000.0);
  EXPECT_DOUBLE_EQ(iv[0].clock.max_us, 1000.0);
  EXPECT_DOUBLE_EQ(iv[0].clock.min_us, 1000.0);
  EXPECT_DOUBLE_EQ(iv[0].clock.mean_us, 1000.0);
  // the same calls, timed on the wall clock (how long each simulated millisecond took here)
  EXPECT_EQ(iv[0].wall.n, 99u);
  EXPECT_LE(iv[0].wall.min_us, iv[0].wall.p50_us);
  EXPECT_LE(iv[0].wall.p50_us, iv[0].wall.p99_us);
  EXPECT_LE(iv[0].wall.p99_us, iv[0].wall.max_us);
}

TEST_F(TimersTest, IntervalsSpanOnlyConsecutiveCallsOfOneRun) {
  dca::TimerServer ts(io, dca::ClockKind::Simulated);
  ts.set_aligned(true);
  auto id = ts.every(kMs, [] {}, "ctrl");
  ts.advance_to(10 * kMs);  // calls at 1..10 ms: 9 intervals
  ts.cancel(id);
  ts.advance_to(50 * kMs);
  id = ts.every(kMs, [] {}, "ctrl");  // run again: 51..60 ms, 9 more; the 41 ms gap is no period
  ts.advance_to(60 * kMs);
  ts.every(2 * kMs, [] {}, "ctrl");  // another period: its own figures
  ts.advance_to(64 * kMs);  // ctrl@1ms: 61..64 (4 more); ctrl@2ms: 62, 64 (1)
  const auto iv = ts.interval_stats();
  ASSERT_EQ(iv.size(), 2u);
  EXPECT_EQ(iv[0].clock.n, 22u);
  EXPECT_DOUBLE_EQ(iv[0].clock.max_us, 1000.0);
  EXPECT_EQ(iv[1].period, 2 * kMs);
  EXPECT_EQ(iv[1].clock.n, 1u);
  EXPECT_DOUBLE_EQ(iv[1].clock.p50_us, 2000.0);
}

TEST_F(TimersTest, ASimulatedClockRunsEveryTickAtItsOwnTime) {
  dca::TimerServer ts(io, dca::ClockKind::Simulated);
  int n = 0;
  ts.every(kMs, [&] { ++n; }, "slow", kMs);
  ts.advance_to(kMs);
  // a master that steps straight to 4 ms runs the calls due at 2, 3 and 4 ms (none is lost on a simulated
  // clock), each at its own deadline: still 1 ms apart on the clock
  ts.advance_to(4 * kMs);
  EXPECT_EQ(n, 4);
  const auto iv = ts.interval_stats();
  ASSERT_EQ(iv.size(), 1u);
  EXPECT_EQ(iv[0].clock.n, 3u);
  EXPECT_DOUBLE_EQ(iv[0].clock.max_us, 1000.0);
}

TEST_F(TimersTest, WallIntervalsAreTheClocksOnTheWallClock) {
  dca::TimerServer ts(io, dca::ClockKind::Wall);
  int n = 0;
  const auto id = ts.every(kMs, [&] { ++n; }, "tick");
  ASSERT_TRUE(run_until(io, [&] { return n >= 20; }));
  ts.cancel(id);
  const auto iv = ts.interval_stats();
  ASSERT_EQ(iv.size(), 1u);
  EXPECT_EQ(iv[0].clock.n, static_cast<std::uint64_t>(n - 1));
  EXPECT_EQ(iv[0].wall.n, iv[0].clock.n);
  EXPECT_DOUBLE_EQ(iv[0].wall.p50_us, iv[0].clock.p50_us);  // one clock, the same samples
  EXPECT_DOUBLE_EQ(iv[0].wall.max_us, iv[0].clock.max_us);
  EXPECT_GT(iv[0].wall.min_us, 0.0);
}

}  // namespace

TEST_F(TimersTest, AlignedPeriodicTimersStartOnMultiplesOfTheirPeriod) {
  dca::TimerServer ts(io, dca::ClockKind::Simulated);
  ts.advance_to(3 * kMs);
  ts.every(10 * kMs, [] {});  // not aligned: 13 ms
  EXPECT_EQ(ts.next_deadline(), 13 * kMs);
  dca::TimerServer al(io, dca::ClockKind::Simulated);
  al.set_aligned(true);
  al.advance_to(3 * kMs);
  int a = 0, b = 0;
  al.every(10 * kMs, [&] { ++a; });
  al.advance_to(7 * kMs);
  al.every(10 * kMs, [&] { ++b; });
  EXPECT_EQ(al.next_deadline(), 10 * kMs);  // both at 10 ms, whenever they were made
  EXPECT_EQ(al.advance_to(10 * kMs), 2u);
  al.advance_to(20 * kMs);  // exactly on a tick: the next one is 30, not 20 again
  al.every(10 * kMs, [&] { ++b; });
  EXPECT_EQ(al.next_deadline(), 30 * kMs);
  EXPECT_EQ(a, 2);
  EXPECT_EQ(b, 2);
}

// The heap of due timers against a model that scans every timer (the order of docs/time.md: deadline, then
// creation): random periodic and one-shot timers, cancelled from outside and from callbacks, timers added by
// callbacks, over 1,500 random advances, with more than the 256 finished timers the server keeps (its clean-up
// rebuilds the heap). The sequence of (name, deadline) fired is the model's.
TEST_F(TimersTest, TheHeapFiresInTheOrderOfAScanOfEveryTimer) {
  struct Model {
    struct T {
      std::string name;
      dca::Nanos deadline, period;
      bool active = true;
    };
    std::vector<T> ts;
  };
  dca::TimerServer s(io, dca::ClockKind::Simulated);
  Model m;
  std::vector<std::string> got, want;
  std::vector<dca::TimerServer::Id> ids;  // the server's id of the model's timer i
  std::uint64_t x = 88172645463325252ull;  // xorshift64: the same sequence every run
  auto rnd = [&](std::uint64_t n) {
    x ^= x << 13, x ^= x >> 7, x ^= x << 17;
    return x % n;
  };
  s.on_fire = [&](const std::string& name, dca::Nanos t) { got.push_back(name + "@" + std::to_string(t)); };
  dca::Nanos now = 0;
  // callbacks: timer i, when it fires, cancels timer (i * 7) % count every third time (model: the same)
  std::function<void(std::size_t)> add = [&](std::size_t unused) {
    (void)unused;
    const std::size_t i = m.ts.size();
    const bool periodic = rnd(3) != 0;
    const dca::Nanos d = static_cast<dca::Nanos>(1 + rnd(20)) * kMs;
    const std::string name = "t" + std::to_string(i);
    m.ts.push_back({name, now + d, periodic ? d : 0});
    auto fn = [&, i] {
      if (i % 3 == 0 && !m.ts.empty()) {
        const std::size_t j = (i * 7) % m.ts.size();
        s.cancel(ids[j]);
      }
    };
    ids.push_back(periodic ? s.every(d, fn, name) : s.after(d, fn, name));
  };
  auto model_advance = [&](dca::Nanos t) {
    for (;;) {
      std::size_t best = m.ts.size();
      for (std::size_t i = 0; i < m.ts.size(); ++i)
        if (m.ts[i].active && m.ts[i].deadline <= t && (best == m.ts.size() || m.ts[i].deadline < m.ts[best].deadline))
          best = i;
      if (best == m.ts.size()) break;
      auto& e = m.ts[best];
      want.push_back(e.name + "@" + std::to_string(e.deadline));
      if (e.period) e.deadline += e.period;
      else e.active = false;
      if (best % 3 == 0) m.ts[(best * 7) % m.ts.size()].active = false;
    }
  };
  for (int round = 0; round < 1500; ++round) {
    const auto op = rnd(10);
    if (op < 4) add(0);
    else if (op < 5 && !m.ts.empty()) {
      const std::size_t j = rnd(m.ts.size());
      m.ts[j].active = false;
      s.cancel(ids[j]);
    }
    const dca::Nanos t = now + static_cast<dca::Nanos>(rnd(15)) * kMs;
    model_advance(t);
    s.advance_to(t);
    now = t;
    ASSERT_EQ(got, want) << "round " << round;
    ASSERT_EQ(s.next_deadline().has_value(), std::any_of(m.ts.begin(), m.ts.end(), [](auto& e) { return e.active; }));
  }
  EXPECT_GT(want.size(), 2000u);
  std::size_t finished = 0;
  for (const auto& e : m.ts) finished += !e.active;
  EXPECT_GT(finished, 256u) << "past what the server keeps: its clean-up ran";
}
