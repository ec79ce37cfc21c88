// host/rt: the lock-free rings, the histograms, the real-time thread's periods and the contract's counters.
// No timed assertion: only counts that follow from the order of events (a sleep of 5 periods skips at least 4).
#include <gtest/gtest.h>

#include <time.h>

#include <atomic>
#include <chrono>
#include <future>
#include <mutex>
#include <thread>

#include "host/rt/contract.h"
#include "host/rt/histogram.h"
#include "host/rt/rt_thread.h"
#include "host/rt/setup.h"
#include "host/rt/spsc_ring.h"

namespace {

using dca::rt::RtThread;
using dca::rt::SpscRing;

TEST(SpscRing, KeepsOrderAndRefusesWhenFull) {
  SpscRing<int, 4> r;
  for (int i = 0; i < 4; ++i) EXPECT_TRUE(r.push(i));
  EXPECT_FALSE(r.push(99));
  EXPECT_EQ(r.size(), 4u);
  int v = -1;
  for (int i = 0; i < 4; ++i) {
    ASSERT_TRUE(r.pop(v));
    EXPECT_EQ(v, i);
  }
  EXPECT_FALSE(r.pop(v));
  EXPECT_TRUE(r.push(5));  // wraps around
  ASSERT_TRUE(r.pop(v));
  EXPECT_EQ(v, 5);
}

TEST(SpscRing, CarriesEveryElementInOrderBetweenTwoThreads) {
  static SpscRing<std::uint64_t, 64> r;
  constexpr std::uint64_t kN = 20'000;
  std::thread producer([] {
    for (std::uint64_t i = 0; i < kN;)
      if (r.push(i)) ++i;
  });
  std::uint64_t expected = 0, v = 0;
  while (expected < kN) {
    if (r.pop(v)) {
      ASSERT_EQ(v, expected++);
    }
  }
  producer.join();
  EXPECT_EQ(r.size(), 0u);
}

TEST(RtHistogram, QuantilesAreBucketEdgesNeverAboveMax) {
  dca::rt::RtHistogram h;
  for (int i = 0; i < 99; ++i) h.record(10'500);  // 10.5 us: bucket [10, 11) us
  h.record(2'345'000);                            // 2.345 ms: a coarse bucket
  EXPECT_EQ(h.count(), 100u);
  EXPECT_EQ(h.quantile(0.5), 11'000);
  EXPECT_EQ(h.quantile(1.0), 2'345'000);
  EXPECT_EQ(h.max(), 2'345'000);
  const auto s = h.summary();
  EXPECT_DOUBLE_EQ(s.p50_us, 11.0);
  EXPECT_DOUBLE_EQ(s.max_us, 2345.0);
  h.record(-5);  // counts as 0
  EXPECT_EQ(h.quantile(0.0), 1'000);
}

TEST(RtSetup, ChecksPriorityAndCpu) {
  dca::rt::RtConfig c;
  EXPECT_EQ(dca::rt::check(c), "");
  c.priority = 120;
  EXPECT_NE(dca::rt::check(c).find("1..99"), std::string::npos);
  c.priority = 80;
  c.cpu = 100000;
  EXPECT_NE(dca::rt::check(c).find("rt cpu"), std::string::npos);
}

// Runs `thread` until `runs` runs of its first task were counted (a promise the task keeps), then stops it.
void run_until(RtThread& thread, std::promise<void>& enough) {
  auto done = enough.get_future();
  thread.start();
  ASSERT_EQ(done.wait_for(std::chrono::seconds(30)), std::future_status::ready);
  thread.stop();
}

TEST(RtThread, RunsEachTaskAtItsPeriodAndCountsIt) {
  dca::rt::RtConfig c;
  c.who = "/t on host h";
  RtThread thread(c);
  std::atomic<int> a{0}, b{0};
  std::promise<void> enough;
  thread.add("a", 1'000'000, [&] {
    if (++a == 20) enough.set_value();
  });
  thread.add("b", 2'000'000, [&] { ++b; });
  run_until(thread, enough);
  const auto s = thread.stats();
  ASSERT_EQ(s.size(), 2u);
  EXPECT_EQ(s[0].name, "a");
  EXPECT_GE(s[0].runs, 20u);
  EXPECT_EQ(s[0].wake.n, s[0].runs);
  EXPECT_EQ(s[0].exec.n, s[0].runs);
  EXPECT_EQ(s[1].period_ns, 2'000'000);
  EXPECT_EQ(static_cast<int>(s[1].runs), b.load());
  EXPECT_FALSE(thread.running());
}

TEST(RtThread, SkipsMissedPeriodsInsteadOfBunchingThem) {
  RtThread thread;
  std::atomic<int> runs{0};
  std::promise<void> enough;
  thread.add("slow", 1'000'000, [&] {
    const int n = ++runs;
    if (n == 1) {  // one run of 5.5 periods
      timespec ts{0, 5'500'000};
      nanosleep(&ts, nullptr);
    }
    if (n == 3) enough.set_value();
  });
  run_until(thread, enough);
  const auto s = thread.stats()[0];
  EXPECT_GE(s.overruns, 1u);
  EXPECT_GE(s.missed, 5u);  // deadlines 1..5 periods after the first went by while it ran: skipped, not run
  EXPECT_GE(s.exec.max_us, 5500.0);
}

TEST(RtThread, StartsWithAWarningNotAFailureWhenRefused) {
  dca::rt::RtConfig c;
  c.priority = 80;
  c.cpu = 0;
  c.who = "/arm on host h";
  RtThread thread(c);
  std::promise<void> enough;
  std::atomic<int> n{0};
  thread.add("x", 1'000'000, [&] {
    if (++n == 3) enough.set_value();
  });
  auto done = enough.get_future();
  const std::string warning = thread.start();  // privileged or not: it runs
  if (!warning.empty()) {
    EXPECT_NE(warning.find("/arm on host h"), std::string::npos) << warning;
  }
  ASSERT_EQ(done.wait_for(std::chrono::seconds(30)), std::future_status::ready);
  thread.stop();
}

TEST(RtContract, CountsAllocationsLocksAndPageFaultsOfTheMarkedThreadOnly) {
  namespace contract = dca::rt::contract;
  ASSERT_TRUE(contract::hooked());
  std::mutex m;
  contract::enter();
  auto* p = new int(3);
  asm volatile("" : : "r"(p) : "memory");  // the allocation stays
  { std::lock_guard<std::mutex> lock(m); }
  const auto c = contract::counts();
  contract::leave();
  delete p;
  EXPECT_EQ(c.allocations, 1u);
  EXPECT_EQ(c.locks, 1u);
  std::thread other([] {  // another thread: not counted
    auto* q = new int(4);
    asm volatile("" : : "r"(q) : "memory");
    delete q;
  });
  other.join();
  contract::enter();
  volatile int sum = 0;
  for (int i = 0; i < 100; ++i) sum = sum + i;
  const auto quiet = contract::counts();
  contract::leave();
  EXPECT_EQ(quiet.allocations, 0u);
  EXPECT_EQ(quiet.locks, 0u);
}

}  // namespace
