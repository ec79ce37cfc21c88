// The lock-step clock master's core (host/lockstep.h) with fake subscribers: no sockets, no clock, no loop.
// The test is the process around it: it counts steps and publishes, runs scheduled ticks by hand, and answers
// each fake subscriber's advances itself.
#include "host/lockstep.h"

#include <gtest/gtest.h>

#include <deque>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace {

using dca::ClockLink;
using dca::LockstepCore;
using dca::Nanos;

constexpr Nanos kMs = 1'000'000;

// A subscriber whose advances wait in a queue until the test answers them.
class FakeLink final : public ClockLink {
 public:
  void request(const std::string& type, dca::wire::Value payload, ReplyFn done) override {
    types.push_back(type);
    payloads.push_back(payload);
    pending.push_back({payload["t"].as_int(-1), std::move(done)});
  }
  // Answers the oldest request: ok with `next` (and `reply`'s other fields), or `error` (replied or not).
  void answer(std::optional<Nanos> next, dca::wire::Value reply = dca::wire::Value::map()) {
    reply.set("next", next ? dca::wire::Value(*next) : dca::wire::Value());
    pop()("", true, reply);
  }
  void fail(const std::string& error, bool replied) { pop()(error, replied, dca::wire::Value()); }
  void close(const std::string& why) override { closed = why; }
  std::string closed;
  struct Pending {
    Nanos t;
    ReplyFn done;
  };
  std::vector<std::string> types;
  std::vector<dca::wire::Value> payloads;
  std::deque<Pending> pending;
  std::vector<Nanos> seen() const {
    std::vector<Nanos> ts;
    for (const auto& p : pending) ts.push_back(p.t);
    return ts;
  }

 private:
  ReplyFn pop() {
    auto done = std::move(pending.front().done);
    pending.pop_front();
    return done;
  }
};

class LockstepTest : public ::testing::Test {
 protected:
  // A 1 ms owner, sync every 10 ms, every node at least every 50 ms; `duration` in seconds (-1: none).
  void make(double duration = -1, bool realtime = false) {
    dca::LockstepOptions o;
    o.period = kMs;
    o.sync_period = 0.01;
    o.idle_period = 0.05;
    o.inline_quiet = inline_quiet;
    o.duration = duration;
    o.realtime = realtime;
    o.cpus = cpus;
    o.spin_us = spin_us;
    dca::LockstepHooks h;
    h.spin = [this](int us) { master_spins.push_back(us); };
    h.step = [this] { ++steps; };
    h.publish = [this] { ++publishes; };
    h.settle = [this] { ++settles; };
    h.schedule = [this](std::optional<Nanos> due) {
      ++scheduled;
      wall_due = due;
    };
    h.wall_now = [this] { return wall; };
    h.writer_gone = [this](const std::string& in) { gone.push_back(in + " before step " + std::to_string(steps)); };
    h.release = [this](const std::vector<std::string>& leaves) {
      std::string l;
      for (const auto& x : leaves) l += (l.empty() ? "" : ",") + x;
      released.push_back(l + " at " + std::to_string(core->now() / kMs) + " ms");
    };
    if (take) h.take = take;
    core = std::make_unique<LockstepCore>(o, h);
    core->on_duration = [this] { ++durations; };
  }
  // Runs the scheduled ticks while one is asked for and no round is open, at most `max` of them.
  int run_ticks(int max) {
    int n = 0;
    while (scheduled > 0 && n < max) {
      --scheduled;
      core->tick();
      ++n;
    }
    return n;
  }
  std::shared_ptr<FakeLink> subscribe(const std::string& name, const void* origin, bool supervisor = false) {
    auto link = std::make_shared<FakeLink>();
    core->subscribe(origin, name, link, supervisor);
    return link;
  }

  bool inline_quiet = false;  // each tick a handler of its own: the tests count them
  std::function<std::string(const dca::wire::Value&)> take;  // the owner's `take` hook, when set before make()
  int cpus = 0, spin_us = -1;      // LockstepOptions', set before make()
  std::vector<int> master_spins;   // hook `spin`: the windows the master polled for answers
  std::unique_ptr<LockstepCore> core;
  int steps = 0, publishes = 0, settles = 0, scheduled = 0, durations = 0;
  std::vector<std::string> gone;  // writer_gone: the owner's inputs that lost their writer, and when
  std::vector<std::string> released;  // release: the leaves whose held samples went out, and when
  std::optional<Nanos> wall_due;
  Nanos wall = 5'000 * kMs;
  int origin_a = 0, origin_b = 0, origin_s = 0;
};

TEST_F(LockstepTest, TimeStandsStillUntilGo) {
  make();
  EXPECT_EQ(scheduled, 0);
  EXPECT_EQ(core->now(), 0);
  EXPECT_TRUE(core->go());
  EXPECT_FALSE(core->go());  // already running: no second schedule
  EXPECT_EQ(scheduled, 1);
  EXPECT_FALSE(wall_due.has_value());  // not paced: at once
}

TEST_F(LockstepTest, WithoutSubscribersTheOwnerStepsAndPublishesNothing) {
  make();
  core->go();
  EXPECT_EQ(run_ticks(25), 25);
  EXPECT_EQ(steps, 25);
  EXPECT_EQ(core->now(), 25 * kMs);
  EXPECT_EQ(publishes, 0);  // it publishes for the nodes due at a tick: none
}

// Unpaced, the quiet ticks (nobody due) run in one handler up to the next sync tick: the same steps and rounds.
TEST_F(LockstepTest, QuietTicksRunInOneHandlerUpToTheNextSyncTick) {
  inline_quiet = true;
  make();
  auto a = subscribe("/a", &origin_a);
  core->go();
  EXPECT_EQ(run_ticks(100), 2);  // ticks 1..9 ms in one handler, then 10 ms (a sync tick), which opens a round
  EXPECT_EQ(steps, 10);
  EXPECT_EQ(a->seen(), std::vector<Nanos>{10 * kMs});
  a->answer(13 * kMs);
  EXPECT_EQ(run_ticks(100), 1);  // 11..13 ms
  EXPECT_EQ(a->seen(), std::vector<Nanos>{13 * kMs});
  a->answer(std::nullopt);
  EXPECT_EQ(run_ticks(1), 1);  // 14..19 ms: the next one is a sync tick, a handler of its own
  EXPECT_EQ(core->now(), 19 * kMs);
  EXPECT_EQ(run_ticks(100), 4);  // 20..29, 30..39, 40..49, then 50 (the idle tick: /a)
  EXPECT_EQ(core->now(), 50 * kMs);
  EXPECT_EQ(a->seen(), std::vector<Nanos>{50 * kMs});
}

TEST_F(LockstepTest, EverySubscriberIsAdvancedAtASyncTickAndTheNextWaitsForAllAnswers) {
  make();
  auto a = subscribe("/a", &origin_a);
  auto b = subscribe("/b", &origin_b);
  core->go();
  EXPECT_EQ(run_ticks(100), 10);  // ticks 1..10 ms; the 10 ms one opens a round
  EXPECT_EQ(a->seen(), std::vector<Nanos>{10 * kMs});
  EXPECT_EQ(b->seen(), std::vector<Nanos>{10 * kMs});
  EXPECT_EQ(scheduled, 0);
  a->answer(std::nullopt);
  EXPECT_EQ(scheduled, 0);  // b has not answered
  b->answer(std::nullopt);
  EXPECT_EQ(scheduled, 1);
  const auto st = core->status();
  EXPECT_EQ(st["rounds"].as_int(0), 1);
  EXPECT_EQ(st["advances"].as_int(0), 2);
  EXPECT_EQ(st["subscribers"].as_array().size(), 2u);
}

TEST_F(LockstepTest, ASubscriberIsAdvancedAtItsNextDeadline) {
  make();
  auto a = subscribe("/a", &origin_a);
  core->go();
  run_ticks(100);
  a->answer(13 * kMs);  // its next timer is at 13 ms
  EXPECT_EQ(run_ticks(100), 3);
  EXPECT_EQ(a->seen(), std::vector<Nanos>{13 * kMs});
  EXPECT_EQ(publishes, 2);  // published before each advance
  a->answer(std::nullopt);
  EXPECT_EQ(run_ticks(100), 37);  // nothing due: left alone until the idle tick at 50 ms
  EXPECT_EQ(a->seen(), std::vector<Nanos>{50 * kMs});
}

// A node that has not answered yet is advanced at the next sync tick; one that answered, only when due (or
// at an idle tick): the leaves the supervisor does not run cost the rounds nothing.
TEST_F(LockstepTest, ANodeIsAdvancedWhenDueAndEveryNodeAtTheIdleTick) {
  make();
  auto a = subscribe("/a", &origin_a);
  auto idle = subscribe("/idle", &origin_b);
  core->go();
  run_ticks(100);
  a->answer(20 * kMs);
  idle->answer(std::nullopt);
  auto late = subscribe("/late", &origin_s);  // e.g. a restarted node
  run_ticks(100);
  EXPECT_EQ(a->seen(), std::vector<Nanos>{20 * kMs});
  EXPECT_EQ(late->seen(), std::vector<Nanos>{20 * kMs});  // its first sync tick
  EXPECT_TRUE(idle->seen().empty());
  a->answer(50 * kMs);
  late->answer(std::nullopt);
  EXPECT_EQ(run_ticks(100), 30);
  EXPECT_EQ(a->seen(), std::vector<Nanos>{50 * kMs});
  EXPECT_EQ(idle->seen(), std::vector<Nanos>{50 * kMs});  // the idle tick: everyone
  EXPECT_EQ(late->seen(), std::vector<Nanos>{50 * kMs});
}

TEST_F(LockstepTest, AStalledSubscriberIsDroppedByNameAndTheOthersGoOn) {
  make();
  auto a = subscribe("/a", &origin_a);
  auto stalled = subscribe("/stalled", &origin_b);
  core->go();
  run_ticks(100);
  a->answer(std::nullopt);
  stalled->fail("timed out after 300 ms", false);
  const auto st = core->status();
  ASSERT_EQ(st["dropped"].as_array().size(), 1u);
  EXPECT_EQ(st["dropped"].as_array()[0].as_string(), "/stalled: did not answer the advance to 0.010000 s (timed out after 300 ms)");
  EXPECT_EQ(st["subscribers"].as_array().size(), 1u);
  EXPECT_EQ(run_ticks(100), 40);
  EXPECT_EQ(a->seen(), std::vector<Nanos>{50 * kMs});
  EXPECT_TRUE(stalled->pending.empty());
}

TEST_F(LockstepTest, ARefusedAdvanceDropsTheSubscriberWithTheReason) {
  make();
  auto a = subscribe("/a", &origin_a);
  core->go();
  run_ticks(100);
  a->fail("not on simulated time", true);
  const auto st = core->status();
  const auto& dropped = st["dropped"].as_array();
  ASSERT_EQ(dropped.size(), 1u);
  EXPECT_EQ(dropped[0].as_string(), "/a: advance to 0.010000 s refused: not on simulated time");
}

TEST_F(LockstepTest, ASecondClockFromTheSameOriginReplacesTheFirst) {
  make();
  subscribe("/old", &origin_a);
  subscribe("/other", &origin_b);
  subscribe("/new", &origin_a);
  const auto st = core->status();
  const auto& names = st["subscribers"].as_array();
  ASSERT_EQ(names.size(), 2u);
  EXPECT_EQ(names[0].as_string(), "/other");
  EXPECT_EQ(names[1].as_string(), "/new");
}

TEST_F(LockstepTest, HoldStopsTimeAfterTheCurrentTick) {
  make();
  core->go();
  run_ticks(3);
  core->hold();
  EXPECT_EQ(run_ticks(100), 1);  // the tick already asked for finds time held
  EXPECT_EQ(core->now(), 3 * kMs);
  EXPECT_FALSE(core->status()["running"].as_bool());
  EXPECT_TRUE(core->go());
  EXPECT_EQ(run_ticks(2), 2);
  EXPECT_EQ(core->now(), 5 * kMs);
}

TEST_F(LockstepTest, TimeHoldsAtTheDurationAndSaysSoOnce) {
  make(0.005);
  core->go();
  EXPECT_EQ(run_ticks(100), 5);
  EXPECT_EQ(core->now(), 5 * kMs);
  EXPECT_EQ(durations, 1);
  EXPECT_TRUE(core->go());
  EXPECT_EQ(run_ticks(3), 3);  // resumed past the duration: no second call
  EXPECT_EQ(durations, 1);
}

TEST_F(LockstepTest, PacedToTheWallClockEachTickIsDueOnePeriodLater) {
  make(-1, true);
  core->go();
  ASSERT_TRUE(wall_due.has_value());
  EXPECT_EQ(*wall_due, wall + kMs);  // time 0 is the wall time of `go`
  run_ticks(1);
  EXPECT_EQ(*wall_due, wall + 2 * kMs);
}

// The pace (docs/time.md, "Pace"): wall deadline = wall0 + t / speed, re-anchored at each change, so a
// change makes the next tick due one period at the new speed after it: no jump, no catching up.
TEST_F(LockstepTest, ASpeedChangeReanchorsThePacing) {
  make(-1, true);
  EXPECT_EQ(core->speed(), 1.0);
  core->go();
  run_ticks(1);
  EXPECT_EQ(*wall_due, wall + 2 * kMs);
  wall += 7 * kMs;  // the wall clock ran ahead of simulated time (a slow subscriber, a paused page...)
  core->set_speed(0.5);
  run_ticks(1);     // the tick asked for before the change (2 ms)
  EXPECT_EQ(core->now(), 2 * kMs);
  // 1 ms was simulated at the change: 3 ms is two periods at half speed after it, not in the past
  EXPECT_EQ(*wall_due, wall + 4 * kMs);
  core->set_speed(10);  // at 2 ms
  run_ticks(1);
  EXPECT_EQ(*wall_due, wall + 2 * kMs / 10);  // 4 ms: two periods at 10x after the change
  EXPECT_EQ(core->status()["speed"].as_float(), 10.0);
  core->set_speed(0);  // as fast as the subscribers allow: at once
  run_ticks(1);
  EXPECT_FALSE(wall_due.has_value());
  EXPECT_EQ(core->now(), 4 * kMs);
}

// Paused for a while, then resumed: the next tick is one period after the resume, no catching up.
TEST_F(LockstepTest, AResumedPacedClockDoesNotCatchUp) {
  make(-1, true);
  core->go();
  run_ticks(1);
  core->hold();
  run_ticks(1);  // the tick asked for finds time held
  EXPECT_EQ(core->now(), kMs);
  wall += 1000 * kMs;  // a second paused
  core->go();
  EXPECT_EQ(*wall_due, wall + kMs);
}

// Unpaced at first (as fast as possible), paced from a `pace` on.
TEST_F(LockstepTest, AnUnpacedClockCanBePacedLater) {
  make();
  EXPECT_EQ(core->speed(), 0.0);
  core->go();
  run_ticks(3);
  EXPECT_FALSE(wall_due.has_value());
  core->set_speed(2);  // at 3 ms
  run_ticks(1);        // 4 ms, asked for unpaced
  EXPECT_EQ(*wall_due, wall + kMs);  // 5 ms: two periods at 2x after the change
}

// Pause is hold; a step is one tick, then time holds again: steps and status t move by one period each.
TEST_F(LockstepTest, AStepIsOneTickThenTimeHolds) {
  make();
  core->go();
  run_ticks(3);
  core->hold();
  run_ticks(100);
  EXPECT_EQ(core->now(), 3 * kMs);
  for (int i = 1; i <= 3; ++i) {
    core->step(false);
    EXPECT_TRUE(core->status()["stepping"].as_bool());
    EXPECT_EQ(run_ticks(100), 1);
    EXPECT_EQ(core->now(), (3 + i) * kMs);
    EXPECT_FALSE(core->running());
    EXPECT_FALSE(core->status()["stepping"].as_bool());
  }
  EXPECT_EQ(steps, 6);
}

// A step to the next event: time runs through quiet ticks and rounds, and holds at the end of the first tick
// that had a barrier (the supervisors' transitions done), not before.
TEST_F(LockstepTest, AStepToTheNextEventHoldsAfterItsBarrier) {
  make();
  auto a = subscribe("/a", &origin_a);
  auto s = subscribe("/sup", &origin_s, true);
  core->step(true);
  run_ticks(100);
  using dca::wire::Value;
  a->answer(12 * kMs);  // 10 ms: nothing happened
  run_ticks(100);
  EXPECT_TRUE(core->running());
  EXPECT_EQ(core->now(), 12 * kMs);
  a->answer(std::nullopt, Value::map().set("ev", 1));  // /a ended at 12 ms: the barrier
  a->answer(std::nullopt, Value::map().set("ev", 1));
  s->answer(std::nullopt, Value::map().set("received", 1).set("sent", 0));
  s->answer(std::nullopt, Value::map().set("received", 1).set("sent", 0));
  a->answer(std::nullopt, Value::map().set("ev", 1));
  EXPECT_FALSE(core->running());
  EXPECT_EQ(run_ticks(100), 0);
  EXPECT_EQ(core->now(), 12 * kMs);
  EXPECT_FALSE(core->status()["stepping"].as_bool());
  core->go();  // resumed: no step pending
  run_ticks(100);
  a->answer(std::nullopt, Value::map().set("ev", 1));
  run_ticks(100);
  EXPECT_TRUE(core->running());
  EXPECT_GT(core->now(), 20 * kMs);
}

TEST_F(LockstepTest, RoundsAreTimedOnTheWallClock) {
  make();
  auto a = subscribe("/a", &origin_a);
  core->go();
  run_ticks(100);
  wall += 250'000;  // the answer takes 250 µs
  a->answer(std::nullopt);
  const auto st = core->status();
  EXPECT_EQ(st["rounds"].as_int(0), 1);
  EXPECT_NEAR(st["round_max_us"].as_float(), 250.0, 1.0);
}

// Data counts: what a writer's answer says it sent on a link reaches the reader with its next advance, and
// only the links that moved since the reader was last told.
TEST_F(LockstepTest, AWritersCountsGoToTheReaderWithItsNextAdvance) {
  make();
  auto a = subscribe("/a", &origin_a);
  auto b = subscribe("/b", &origin_b);
  core->go();
  run_ticks(100);
  using dca::wire::Value;
  const Value sent = Value::map().set("/b", Value::map().set("/a|Out>/b|In@s", 3));
  b->answer(std::nullopt);
  a->answer(std::nullopt, Value::map().set("sent", sent));
  run_ticks(100);
  ASSERT_EQ(b->payloads.size(), 2u);
  EXPECT_FALSE(b->payloads[0].find("expect"));  // at 10 ms nothing was counted yet (then: the idle tick)
  EXPECT_EQ(b->payloads[1]["expect"]["/a|Out>/b|In@s"].as_int(0), 3);
  EXPECT_FALSE(a->payloads[1].find("expect"));
  a->answer(std::nullopt);
  b->answer(std::nullopt);
  run_ticks(100);
  EXPECT_FALSE(b->payloads[2].find("expect"));  // unchanged: not said again
}

// A command counted for the owner that never came (its `take` gave up, naming it): time cannot go on. It holds,
// the owner's process is told why, once (the world then stops: a run no longer waits for ever, unsaid).
TEST_F(LockstepTest, ACountedSampleForTheOwnerThatNeverCameStopsTimeAndSaysWhy) {
  using dca::wire::Value;
  std::vector<std::string> expected;
  take = [&](const Value& expect) -> std::string {
    for (const auto& [key, n] : expect.as_map()) expected.push_back(key.as_string() + "=" + std::to_string(n.as_int(0)));
    return "advance: world waited 5000 ms for sample 1 of /a|Cmd, got 0";
  };
  make();
  std::vector<std::string> stuck;
  core->on_stuck = [&](const std::string& why) { stuck.push_back(why); };
  auto a = subscribe("/a", &origin_a);
  core->go();
  run_ticks(100);
  a->answer(std::nullopt, Value::map().set("sent", Value::map().set("world", Value::map().set("/a|Cmd>world|cmd@s", 1))));
  run_ticks(100);
  EXPECT_EQ(expected, (std::vector<std::string>{"/a|Cmd>world|cmd@s=1"}));
  ASSERT_EQ(stuck.size(), 1u);
  EXPECT_EQ(stuck[0], "time cannot go on at 0.010000 s: advance: world waited 5000 ms for sample 1 of /a|Cmd, got 0");
  EXPECT_EQ(core->now(), 10 * kMs);
  run_ticks(100);
  EXPECT_EQ(stuck.size(), 1u);
  EXPECT_EQ(core->now(), 10 * kMs) << "time holds";
  const auto dropped = core->status()["dropped"].as_array();
  ASSERT_EQ(dropped.size(), 1u);
  EXPECT_EQ(dropped[0].as_string(), "time held at 0.010000 s: advance: world waited 5000 ms for sample 1 of /a|Cmd, got 0");
}

// Spinning: while every process on the clock, the master's included, has a CPU of its own, an advance asks its
// node to poll for the next one and the master polls for the answers; with more processes than CPUs, paced to
// the wall clock, or set off, neither. A set window applies whatever the count.
TEST_F(LockstepTest, AdvancesAskToSpinWhileEveryProcessOnTheClockHasACpu) {
  cpus = 2;
  make();
  auto a = subscribe("/a", &origin_a);
  auto s = subscribe("/sup", &origin_s, true);  // a supervisor is not advanced: no CPU of the round
  core->go();
  run_ticks(100);
  ASSERT_EQ(a->payloads.size(), 1u);
  EXPECT_EQ(a->payloads[0]["spin"].as_int(0), dca::kAutoSpinUs);
  EXPECT_EQ(master_spins, std::vector<int>{dca::kAutoSpinUs});
  auto b = subscribe("/b", &origin_b);  // three processes on two CPUs
  a->answer(std::nullopt);
  run_ticks(100);
  ASSERT_GE(b->payloads.size(), 1u);
  EXPECT_FALSE(b->payloads.back().find("spin"));
  EXPECT_EQ(master_spins.size(), 1u) << "no more polling for answers";
  (void)s;
}

TEST_F(LockstepTest, ASetSpinWindowAppliesAndOffOrPacedNeverSpins) {
  // one node on a fresh clock with these options (paced: its first tick at the wall time asked for): the
  // spin its first advance asks for, 0 for none
  auto first_spin = [&](int cpus_now, int spin_now, bool paced) {
    cpus = cpus_now;
    spin_us = spin_now;
    make(-1, paced);
    auto a = subscribe("/a", &origin_a);
    core->go();
    run_ticks(100);
    if (paced) wall = *wall_due;
    run_ticks(100);
    EXPECT_EQ(a->payloads.size(), 1u);
    return a->payloads.empty() ? -1 : static_cast<int>(a->payloads[0]["spin"].as_int(0));
  };
  EXPECT_EQ(first_spin(1, 300, false), 300) << "a set window, whatever the CPUs";
  EXPECT_EQ(first_spin(8, 0, false), 0) << "off";
  EXPECT_EQ(first_spin(8, -1, true), 0) << "paced to the wall clock";
  EXPECT_EQ(master_spins, std::vector<int>{300});
}

// The barrier: an event in a round holds time until every supervisor has answered two waves of quiesce
// with the same counts, every event sent received; every node is advanced to the same t before and after.
TEST_F(LockstepTest, AnEventHoldsTimeUntilTheSupervisorsHaveHandledIt) {
  make();
  auto a = subscribe("/a", &origin_a);
  auto s = subscribe("/sup", &origin_s, true);
  core->go();
  run_ticks(100);
  using dca::wire::Value;
  a->answer(std::nullopt, Value::map().set("ev", 1));  // /a ended at 10 ms
  ASSERT_EQ(a->types.size(), 2u);                      // the sync before the waves
  EXPECT_EQ(a->types[1], "advance");
  EXPECT_EQ(a->pending.front().t, 10 * kMs);
  a->answer(std::nullopt, Value::map().set("ev", 1));
  ASSERT_EQ(s->types.size(), 1u);
  EXPECT_EQ(s->types[0], "quiesce");
  s->answer(std::nullopt, Value::map().set("received", 0).set("sent", 0));  // not yet received
  s->answer(std::nullopt, Value::map().set("received", 1).set("sent", 0));  // received, counts moved
  EXPECT_EQ(scheduled, 0);
  s->answer(std::nullopt, Value::map().set("received", 1).set("sent", 0));  // stable
  ASSERT_EQ(a->types.size(), 3u);  // the sync after the waves
  EXPECT_EQ(scheduled, 0);
  a->answer(std::nullopt, Value::map().set("ev", 1));
  EXPECT_EQ(scheduled, 1);
  EXPECT_EQ(core->now(), 10 * kMs);
  EXPECT_EQ(core->status()["barriers"].as_int(0), 1);
  EXPECT_EQ(core->status()["waves"].as_int(0), 3);
}

// A node dropped from the clock is told so (its link closed: a node that still lives stops), so its supervisor
// hears of its exit; a supervisor dropped is not (its link is its own channel to the world).
TEST_F(LockstepTest, ADroppedNodeIsToldAndASupervisorIsNot) {
  make();
  auto a = subscribe("/a", &origin_a);
  auto b = subscribe("/b", &origin_b);
  core->go();
  run_ticks(100);
  a->answer(std::nullopt);
  b->fail("timed out after 300 ms", false);
  EXPECT_EQ(b->closed, "dropped from the clock: /b: did not answer the advance to 0.010000 s (timed out after 300 ms)");
  EXPECT_EQ(a->closed, "");
}

// A restarted reader (a new process subscribing under the leaf's name) starts its links' counts afresh: it is
// never told to wait for the samples its old process's links carried, and its new writer's counts from zero
// reach it as they come. The same for a restarted writer: its new link's counts replace the old ones.
TEST_F(LockstepTest, ARestartedLeafsLinksStartTheirCountsAfresh) {
  make();
  using dca::wire::Value;
  const std::string key = "/a|Out>/b|In@s";
  auto a = subscribe("/a", &origin_a);
  auto b = subscribe("/b", &origin_b);
  // each node is due again 10 ms after each advance (a node with nothing due is left alone)
  auto next = [](const std::shared_ptr<FakeLink>& l) { return l->pending.front().t + 10 * kMs; };
  core->go();
  run_ticks(100);
  b->answer(next(b));
  a->answer(next(a), Value::map().set("sent", Value::map().set("/b", Value::map().set(key, 500))));
  run_ticks(100);
  EXPECT_EQ(b->payloads[1]["expect"][key].as_int(0), 500);
  a->answer(next(a));
  b->answer(next(b));
  // /b restarts: a new process (another origin) subscribes under its name; the old one is gone
  core->unsubscribe(&origin_b);
  int origin_b2 = 0;
  auto b2 = subscribe("/b", &origin_b2);
  run_ticks(100);
  EXPECT_FALSE(b2->payloads[0].find("expect"));  // not told to wait for the old link's 500
  b2->answer(next(b2));
  a->answer(next(a), Value::map().set("sent", Value::map().set("/b", Value::map().set(key, 2))));
  run_ticks(100);
  EXPECT_EQ(b2->payloads[1]["expect"][key].as_int(0), 2);
  a->answer(next(a));
  b2->answer(next(b2));
  // /a restarts: its new link counts from 0 again, and the reader is told the new count, however small
  core->unsubscribe(&origin_a);
  int origin_a2 = 0;
  auto a2 = subscribe("/a", &origin_a2);
  run_ticks(100);
  b2->answer(next(b2));
  a2->answer(next(a2), Value::map().set("sent", Value::map().set("/b", Value::map().set(key, 1))));
  run_ticks(100);
  EXPECT_EQ(b2->payloads[3]["expect"][key].as_int(0), 1);
}

// The owner's inputs a leaf wrote to are told their writer is gone at the tick its node is lost (before the
// owner's next step) and when a new instance of it subscribes (a restart by hand); its other links are not.
TEST_F(LockstepTest, TheOwnersInputsAreToldTheirWriterIsGone) {
  make();
  using dca::wire::Value;
  const Value sent = Value::map()
                         .set("world", Value::map().set("/d|Cmd>world|base.cmd_vel@/d:device", 3))
                         .set("/b", Value::map().set("/d|Out>/b|In@s", 3));
  auto d = subscribe("/d", &origin_a);
  core->go();
  run_ticks(100);
  d->answer(d->pending.front().t + 10 * kMs, Value::map().set("sent", sent));
  EXPECT_TRUE(gone.empty());
  run_ticks(100);
  const int at = steps;
  d->fail("timed out after 300 ms", false);  // lost at the tick of 20 ms
  ASSERT_EQ(gone.size(), 1u);
  EXPECT_EQ(gone[0], "base.cmd_vel before step " + std::to_string(at));
  // its new instance subscribing (it has written nothing yet): told again, harmless, and its links forgotten
  int origin_d2 = 0;
  auto d2 = subscribe("/d", &origin_d2);
  ASSERT_EQ(gone.size(), 2u);
  EXPECT_EQ(gone[1], "base.cmd_vel before step " + std::to_string(at));
  // a restart by hand: the new instance's link writes, then another instance subscribes
  run_ticks(100);
  d2->answer(d2->pending.front().t + 10 * kMs, Value::map().set("sent", sent));
  run_ticks(100);
  int origin_d3 = 0;
  subscribe("/d", &origin_d3);
  ASSERT_EQ(gone.size(), 3u);
  EXPECT_EQ(gone[2], "base.cmd_vel before step " + std::to_string(steps));
}

// A leaf added again to a shared node (remove, then add: a restart in the same process) is a new instance: its
// links' counts start afresh, and its events go on counting from those of its old instance.
// The owner's samples to a node on the clock wait for that node's advance (docs/time.md, "Samples to due nodes
// only"): clocked() names the leaves the nodes host (a node's own name until it says which), and each advance
// releases its node's leaves just before it goes out, so an idle node is sent nothing.
TEST_F(LockstepTest, TheOwnersSamplesGoToANodeWithItsAdvanceOnly) {
  make();
  auto a = subscribe("/a", &origin_a);
  auto n = subscribe("leaves:g@h#1", &origin_b);
  EXPECT_TRUE(core->clocked("/a"));
  EXPECT_TRUE(core->clocked("leaves:g@h#1"));
  core->set_leaves(&origin_b, {"/r", "/x"});
  EXPECT_TRUE(core->clocked("/r"));
  EXPECT_FALSE(core->clocked("leaves:g@h#1"));
  EXPECT_FALSE(core->clocked("tap:1"));  // no node of the clock: sent at once
  core->go();
  run_ticks(100);
  EXPECT_EQ(released, (std::vector<std::string>{"/a at 10 ms", "/r,/x at 10 ms"}));
  a->answer(12 * kMs);
  n->answer(std::nullopt);
  run_ticks(100);
  EXPECT_EQ(released.back(), "/a at 12 ms");  // the idle shared node is not released
  EXPECT_EQ(released.size(), 3u);
  core->unsubscribe(&origin_a);
  EXPECT_FALSE(core->clocked("/a"));
}

TEST_F(LockstepTest, ALeafAddedAgainToASharedNodeStartsAfresh) {
  make();
  using dca::wire::Value;
  const std::string key = "/w|Out>/r|In@s";
  auto w = subscribe("/w", &origin_a);
  auto n = subscribe("leaves:g@h#1", &origin_b);
  core->set_leaves(&origin_b, {"/r", "/x"});
  core->go();
  run_ticks(100);
  n->answer(std::nullopt);
  w->answer(std::nullopt, Value::map().set("sent", Value::map().set("/r", Value::map().set(key, 7))));
  run_ticks(100);
  EXPECT_EQ(n->payloads[1]["expect"][key].as_int(0), 7);
  w->answer(std::nullopt);
  n->answer(std::nullopt);
  core->set_leaves(&origin_b, {"/x"});
  core->set_leaves(&origin_b, {"/r", "/x"});
  run_ticks(100);
  EXPECT_FALSE(n->payloads[2].find("expect"));
}

// The barrier counts a leaf's losses: a leaf restarted after its node was lost can be lost again, and its
// supervisor is told to wait for that second exit too.
TEST_F(LockstepTest, QuiesceCountsTheLossesOfEachLeaf) {
  make();
  using dca::wire::Value;
  auto a = subscribe("/a", &origin_a);
  auto s = subscribe("/sup", &origin_s, true);
  core->go();
  run_ticks(100);
  a->fail("closed", false);
  ASSERT_EQ(s->payloads.size(), 1u);
  EXPECT_EQ(s->payloads[0]["lost"]["/a"].as_int(0), 1);
  s->answer(std::nullopt, Value::map().set("received", 1).set("sent", 0));
  s->answer(std::nullopt, Value::map().set("received", 1).set("sent", 0));
  int origin_a2 = 0;
  auto a2 = subscribe("/a", &origin_a2);
  run_ticks(100);
  a2->fail("closed", false);
  EXPECT_EQ(s->payloads.back()["lost"]["/a"].as_int(0), 2);
}

}  // namespace
