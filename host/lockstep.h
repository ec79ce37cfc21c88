#pragma once
// The lock-step clock master (ARCHITECTURE.md, "Time"): the process that owns simulated time (the simulated
// world, a log replay, a real robot's driver) and advances every node on it, one period at a time.
//
// Two layers, as the frame codec and the channel are:
//   - LockstepCore is pure: the subscriber table, the rounds of advances, go/hold, the drop of a subscriber
//     that did not answer (named), and the figures of `status`. It reads no clock and opens no socket: the
//     process gives it hooks (step, publish, settle, schedule, the wall clock) and feeds it events (tick, the
//     answers of its ClockLinks), so tests/host/lockstep_test.cpp drives it with fake subscribers.
//   - Lockstep is the thin shell on a Loop: ticks are posted (or paced to the wall clock on a timer), a
//     subscriber's link is its control channel, and it serves the control requests below.
//
// Requests (Lockstep::handle):
//   clock {name}  -> ok {now}   the channel's node subscribes to `advance` (host/node.h); dropped when its
//                                channel closes or it does not answer an advance in time
//   go {}         -> ok {now}   time starts (or resumes) flowing
//   hold {}       -> ok {now}   time stops after the current tick
//   status {}     -> ok {now, t, running, steps, wall_s, subscribers = [names], dropped = [reasons], rounds,
//                       advances, round_p50_us, round_p99_us, round_max_us}: a round is one tick with
//                       subscribers due (advances sent -> last reply), in wall time
//
// Each tick: the owner steps one period to t (hook `step`); then, if any subscriber is due (its next deadline
// <= t, or t is a multiple of the sync period, when every subscriber is advanced so that one whose timers were
// just made is woken), the owner publishes (hook `publish`), what is in flight is delivered (hook `settle`),
// `advance {t}` goes to each due subscriber, and the next tick waits for every answer (each answer's `next` is
// remembered), after which what they wrote is delivered (`settle`). A subscriber that does not answer within
// the tick timeout is dropped with a message naming it.
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "host/loop.h"  // before any other Asio header (it includes steady_timer)
#include "host/timers.h"
#include "host/wire.h"

namespace dca {

class Channel;

/// A subscriber as the clock master sees it: where its `advance {t}` goes.
class ClockLink {
 public:
  /// The answer to one advance: error "" and the subscriber's next deadline (nullopt: none), or why not;
  /// `replied` is false when no answer came at all (timeout, closed link).
  using AdvanceFn = std::function<void(const std::string& error, bool replied, std::optional<Nanos> next)>;
  virtual ~ClockLink() = default;
  /// Sends `advance {t}`; calls `done` exactly once, later.
  virtual void advance(Nanos t, AdvanceFn done) = 0;
};

/// How the clock master runs.
struct LockstepOptions {
  Nanos period = 1'000'000;       ///< one step of the owner (ns)
  double sync_period = 0.01;      ///< s: every subscriber is advanced at least this often
  int tick_timeout_ms = 10000;    ///< how long a subscriber may take to answer an advance
  bool realtime = false;          ///< pace time to the wall clock (else as fast as the subscribers allow)
  double duration = -1;           ///< s of simulated time after which time holds (-1: never)
  std::string log_name = "dca lockstep";  ///< prefix of its messages on stderr
};

/// What the clock master asks of the process it runs in.
struct LockstepHooks {
  std::function<bool()> ready;    ///< time stays put while this says false (empty: always ready)
  std::function<void()> step;     ///< the owner steps one period, from now() to now() + period
  std::function<void()> publish;  ///< the owner writes its outputs for the subscribers about to be advanced
  std::function<void()> settle;   ///< delivers what is in flight (Loop::settle)
  /// Calls LockstepCore::tick once, later: at once, or when the wall clock reaches `wall_due` (ns).
  std::function<void(std::optional<Nanos> wall_due)> schedule;
  std::function<Nanos()> wall_now;  ///< the wall clock (ns, CLOCK_MONOTONIC)
};

/// The clock master's logic, without sockets or clocks of its own.
class LockstepCore {
 public:
  LockstepCore(LockstepOptions options, LockstepHooks hooks);
  LockstepCore(const LockstepCore&) = delete;
  LockstepCore& operator=(const LockstepCore&) = delete;

  /// `clock {name}`: subscribes `name` through `link`. A later subscription from the same `origin` (the
  /// connection it came on; never dereferenced) replaces this one.
  void subscribe(const void* origin, std::string name, std::shared_ptr<ClockLink> link);
  /// `go`: time starts (or resumes) flowing. True if it was held.
  bool go();
  /// `hold`: time stops after the current tick.
  void hold() { running_ = false; }
  /// The tick the schedule hook was asked for is due.
  void tick();

  /// Simulated time (ns).
  Nanos now() const { return steps_ * period_; }
  bool running() const { return running_; }
  /// The clock's part of `status` (see the file comment).
  wire::Value status() const;
  /// Called once when `duration` is reached (time then holds).
  std::function<void()> on_duration;

 private:
  struct Subscriber {
    const void* origin;
    std::string name;
    std::shared_ptr<ClockLink> link;
    std::optional<Nanos> next;
  };
  std::vector<std::uint64_t> due_at(Nanos t) const;
  void advance(const std::vector<std::uint64_t>& due, Nanos t);
  void answered(std::uint64_t id, Nanos t, const std::string& error, bool replied, std::optional<Nanos> next);
  void drop(std::uint64_t id, const std::string& why);
  void after_tick();
  void schedule();

  LockstepOptions opts_;
  LockstepHooks hooks_;
  Nanos period_, sync_, duration_;
  std::map<std::uint64_t, Subscriber> subs_;  // by subscription order
  std::uint64_t next_sub_ = 1;
  std::vector<std::string> dropped_;
  long steps_ = 0;
  bool running_ = false, scheduled_ = false, duration_hit_ = false, on_duration_pending_ = true;
  int waiting_ = 0;  // advances not yet answered (+1 while they are being sent)
  Nanos wall0_ = 0;  // the wall time at which simulated time would have been 0
  double wall_s_ = 0;  // wall time spent stepping and publishing while running
  // Wall time of each round (advances sent -> last answer): what a simulated control period costs in real time.
  LatenessHistogram rounds_;
  Nanos round0_ = 0;
  std::uint64_t advances_ = 0;  // advances answered
  std::shared_ptr<bool> alive_ = std::make_shared<bool>(true);
};

/// The clock master on a Loop: LockstepCore with its ticks on the loop and its subscribers' control channels
/// as their links.
class Lockstep {
 public:
  /// `hooks` needs only ready/step/publish: the rest are the loop's.
  Lockstep(Loop& loop, LockstepOptions options, LockstepHooks hooks);
  Lockstep(const Lockstep&) = delete;
  Lockstep& operator=(const Lockstep&) = delete;

  /// A node's request hook (Node::on_request): clock, go, hold, status. False for any other type.
  bool handle(const std::shared_ptr<Channel>& ch, const wire::Message& m);
  /// Starts time flowing (as `go`).
  void go();
  /// Simulated time (ns).
  Nanos now() const { return core_.now(); }
  /// The clock's part of `status`.
  wire::Value status() const { return core_.status(); }
  /// Called once when the duration is reached (time then holds).
  std::function<void()> on_duration;
  /// Called once, with why, when the channel that said `go` (the master: a run's root) has closed: time then
  /// holds. A world whose master died would otherwise run on alone at full speed (the owner exits).
  std::function<void(const std::string&)> on_master_lost;

 private:
  void schedule(std::optional<Nanos> wall_due);
  void watch_master();

  Loop& loop_;
  LockstepOptions opts_;
  boost::asio::steady_timer timer_, master_timer_;
  std::weak_ptr<Channel> master_;
  std::string master_peer_;
  LockstepCore core_;
  std::shared_ptr<bool> alive_ = std::make_shared<bool>(true);
};

}  // namespace dca
