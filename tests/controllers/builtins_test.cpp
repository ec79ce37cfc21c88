// The built-in controllers on simulated time: Timer, Deadline, Constant, Gain, Sum, Threshold, Counter, Crash.
#include "controllers/builtins.h"

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>

#include "tests/support/controller_fixture.h"

namespace {

class BuiltinsTest : public dca::testing::ControllerFixture {};

TEST_F(BuiltinsTest, TimerEndsDoneWithTimeoutAfterItsSeconds) {
  auto& t = make("Timer", {"0.03"}, "/timeout");
  ASSERT_EQ(started(t), "");
  timers.advance_to(29 * kMs);
  EXPECT_TRUE(events.empty());
  timers.advance_to(30 * kMs);
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].second.kind, dca::ComponentEvent::Kind::Done);
  EXPECT_EQ(unpack_string(events[0].second.value), "timeout");
}

TEST_F(BuiltinsTest, TimerStopsCountingWhenStopped) {
  auto& t = make("Timer", {"0.01"}, "/timeout");
  ASSERT_EQ(started(t), "");
  timers.advance_to(5 * kMs);
  t.halt();
  timers.advance_to(50 * kMs);
  EXPECT_TRUE(events.empty());
  ASSERT_EQ(started(t), "");  // each start counts afresh
  timers.advance_to(59 * kMs);
  EXPECT_TRUE(events.empty());
  timers.advance_to(60 * kMs);
  EXPECT_EQ(events.size(), 1u);
}

TEST_F(BuiltinsTest, DeadlineEndsAborted) {
  auto& d = make("Deadline", {"0.5"}, "/deadline");
  ASSERT_EQ(started(d), "");
  timers.advance_to(500 * kMs);
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].second.kind, dca::ComponentEvent::Kind::Aborted);
  EXPECT_EQ(events[0].second.reason, "deadline of 0.5 s passed");
}

TEST_F(BuiltinsTest, ConstantThroughGainAndSum) {
  auto& c = make("Constant", {"0.001", "1", "2", "3"}, "/c");
  auto& g = make("Gain", {"10"}, "/g");
  auto& s = make("Sum", {}, "/s");
  connect("/c", "Out", "/g", "In");
  connect("/c", "Out", "/s", "In1");
  connect("/g", "Out", "/s", "In2");
  ep.activate("s");
  for (auto* x : {&s, &g, &c}) ASSERT_EQ(started(*x), "");
  timers.advance_to(1 * kMs);
  const auto& out = *s.ports().find_output("Out");
  ASSERT_TRUE(out.has_latest());
  msgpack::sbuffer sb;
  msgpack::packer<msgpack::sbuffer> pk(sb);
  out.pack_latest(pk);
  EXPECT_EQ(msgpack::unpack(sb.data(), sb.size()).get().as<std::vector<double>>(), (std::vector<double>{11, 22, 33}));
}

TEST_F(BuiltinsTest, SumOfDifferentSizesAborts) {
  auto& a = make("Constant", {"0", "1", "2"}, "/a");
  auto& b = make("Constant", {"0", "1"}, "/b");
  auto& s = make("Sum", {}, "/s");
  connect("/a", "Out", "/s", "In1");
  connect("/b", "Out", "/s", "In2");
  ep.activate("s");
  ASSERT_EQ(started(s), "");
  ASSERT_EQ(started(a), "");
  ASSERT_EQ(started(b), "");
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].first, "/s");
  EXPECT_EQ(events[0].second.reason, "Sum: In1 has 2 values but In2 has 1");
}

TEST_F(BuiltinsTest, ThresholdIsDoneWithTheValueWhenTheSignalCrosses) {
  auto& n = make("Counter", {"0.001"}, "/n");
  auto& t = make("Threshold", {"3.5"}, "/t");
  connect("/n", "Count", "/t", "In");
  ep.activate("s");
  ASSERT_EQ(started(t), "");
  ASSERT_EQ(started(n), "");
  timers.advance_to(10 * kMs);
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].first, "/t");
  EXPECT_EQ(unpack_double(events[0].second.value), 4.0);
}

TEST_F(BuiltinsTest, FallingThresholdIgnoresRisingCrossings) {
  auto& n = make("Counter", {"0.001"}, "/n");
  auto& t = make("Threshold", {"2.5", "falling"}, "/t");
  connect("/n", "Count", "/t", "In");
  ep.activate("s");
  ASSERT_EQ(started(t), "");
  ASSERT_EQ(started(n), "");
  timers.advance_to(10 * kMs);
  EXPECT_TRUE(events.empty());
}

TEST_F(BuiltinsTest, CounterIsDoneAtItsLimit) {
  auto& n = make("Counter", {"0.002", "5"}, "/n");
  ASSERT_EQ(started(n), "");
  timers.advance_to(100 * kMs);
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(unpack_double(events[0].second.value), 5.0);
  EXPECT_EQ(n.ticks(), 5u);  // its timer stopped with the DONE
}

TEST_F(BuiltinsTest, CrashDiesBySegvAtItsTick) {
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    auto& c = make("Crash", {"3"}, "/crash");
    if (!started(c).empty()) ::_exit(2);
    timers.advance_to(2 * kMs);  // two ticks: alive
    timers.advance_to(3 * kMs);  // third: dies
    ::_exit(0);
  }
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFSIGNALED(status)) << "exit status " << status;
  EXPECT_EQ(WTERMSIG(status), SIGSEGV);
}

TEST_F(BuiltinsTest, CrashCanAbort) {
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    auto& c = make("Crash", {"1", "abort"}, "/crash");
    if (!started(c).empty()) ::_exit(2);
    timers.advance_to(1 * kMs);
    ::_exit(0);
  }
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFSIGNALED(status));
  EXPECT_EQ(WTERMSIG(status), SIGABRT);
}

}  // namespace
