#pragma once
// The lock-step clock master (docs/time.md): the process that owns simulated time (the simulated
// world, a log replay, a real robot's driver) and advances every node on it, one period at a time, and waits
// for every supervisor to have handled what happened before it moves on.
//
// Two layers, as the frame codec and the channel are:
//   - LockstepCore is pure: the subscriber table, the rounds of advances, the data counts, the barrier after
//     an event, go/hold, the drop of a subscriber that did not answer (named), and the figures of `status`.
//     It reads no clock and opens no socket: the process gives it hooks (step, publish, settle, schedule, the
//     wall clock, its own data counts) and feeds it events (tick, the answers of its ClockLinks), so
//     tests/host/lockstep_test.cpp drives it with fake subscribers.
//   - Lockstep is the thin shell on a Loop: ticks are posted (or paced to the wall clock on a timer), a
//     subscriber's link is its control channel, and it serves the control requests below.
//
// Requests (Lockstep::handle):
//   clock {name, role}  -> ok {now}  role "node" (default): the channel's node subscribes to `advance`
//                                (host/node.h); "supervisor": the supervisor takes part in the barrier
//                                (`quiesce`, below), answered ok {now, events, lost}: the counts so far, which
//                                a supervisor started anew (a restarted group) already has (they are of
//                                processes before it). Dropped when it does not answer in time (a node's
//                                channel is then closed: it stops). A node subscribing under a leaf's name,
//                                or hosting a leaf it did not host before, is a new process or instance of
//                                it: every count of a link into or out of that leaf is forgotten (a restart)
//   unclock {}     (event)       the subscriber leaves in order (a node that stops): not counted as lost
//   leaves {leaves} (event)      the components a (shared) node hosts, sent when they change
//   go {}           -> ok {now}  time starts (or resumes) flowing
//   hold {at}       -> ok {now}  time stops after the current tick (at: ns, once it reaches `at`)
//   pace {speed}    -> ok {now, speed}  simulated seconds per wall second (0.1 to 10; 0: as fast as the
//                                subscribers allow), from this tick on: the pacing is re-anchored, time never jumps
//   step {to}       -> ok {now}  to "tick" (default): one tick, then time holds; "event": time runs to the end of
//                                the next tick with a barrier (a process sent done or aborted, or was lost: the
//                                tick at which the supervisors make their transitions), then holds
//   status {}       -> ok {now, t, running, speed, stepping, steps, wall_s, run_wall_s, subscribers = [names], dropped = [reasons], rounds,
//                       advances, round_p50_us, round_p99_us, round_max_us, settled, barriers, waves}: a round is one
//                       tick with subscribers due (advances sent -> last reply), in wall time; settled:
//                       no round or barrier open; wall_s: wall time the owner spent stepping and publishing
//                       (step_s: of it, in its step hook; take_s: taking in the samples counted for it);
//                       rounds_s, barrier_s: wall time in the rounds and in the barriers;
//                       run_wall_s: wall time since time first started (the run without its start-up)
//
// Each tick t (the semantics are docs/time.md):
//   1. the owner takes in the samples written to it before t (hook `take`, with the counts its writers
//      reported) and steps one period to t (hook `step`);
//   2. if a node is due (its next deadline <= t; one that has not answered yet at each multiple of the sync
//      period; every node at each multiple of the idle period), the owner publishes
//      (hook `publish`; its counts from hook `sent`), and `advance {t, expect}` goes to each due node, where
//      expect = for each link into it, the samples its writer had sent by its last answer; each answer says
//      its next deadline, its events so far and the links whose counts moved;
//   3. if a node sent an event (done, aborted) or was lost in that round, the barrier: every node is advanced
//      to t (so every clock reads t), then waves of `quiesce {t, events, lost}` go to every supervisor until
//      two waves in a row answer the same counts and every event sent has been received (each supervisor
//      first waits for the events of its own leaves counted in `events` = {node = events so far} and for the
//      exits counted in `lost` = {leaf = nodes of it lost so far} (a restarted leaf can be lost again), handles them in (time, name) order, and answers when it has nothing left to
//      do: Mattern's counting), then every node is advanced to t again (what the reactions wrote, e.g. a
//      stopped drive's zero, is counted at t);
//   4. the next tick.
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "host/loop.h"  // before any other Asio header (it includes steady_timer)
#include "host/codec/wire.h"
#include "host/timers.h"

namespace dca {

class Channel;

/// A subscriber as the clock master sees it: where its `advance` (node) or `quiesce` (supervisor) goes.
class ClockLink {
 public:
  /// The answer to one request: error "" and the reply's payload, or why not; `replied` is false when no
  /// answer came at all (timeout, closed link).
  using ReplyFn = std::function<void(const std::string& error, bool replied, const wire::Value& reply)>;
  virtual ~ClockLink() = default;
  /// Sends the request `type` with `payload`; calls `done` exactly once, later.
  virtual void request(const std::string& type, wire::Value payload, ReplyFn done) = 0;
  /// The subscriber was dropped from the clock (`why`): a node is told so by its link closing, and stops.
  virtual void close(const std::string& why) { (void)why; }
};

/// How the clock master runs.
struct LockstepOptions {
  Nanos period = 1'000'000;       ///< one step of the owner (ns)
  double sync_period = 0.01;      ///< s: a subscriber that has not answered yet is advanced at its multiples
  /// s: every subscriber is advanced at least this often (a node with nothing due, e.g. only idle leaves, is
  /// otherwise left alone: this bounds the samples its gates hold and wakes timers made outside a barrier)
  double idle_period = 1.0;
  int tick_timeout_ms = 10000;    ///< how long a subscriber may take to answer an advance
  bool realtime = false;          ///< pace time to the wall clock at 1x from the start (else unpaced; `pace` changes it)
  /// unpaced, a tick with nobody due is followed at once by the next, in the same loop handler, up to the next
  /// sync tick (else each tick is a handler of its own)
  bool inline_quiet = true;
  double duration = -1;           ///< s of simulated time after which time holds (-1: never)
  std::string log_name = "dca lockstep";  ///< prefix of its messages on stderr
  std::string owner = "world";    ///< the owner's component name (links into it are counted for `take`)
  bool trace = false;             ///< ask the nodes for their outputs' digests (hook `trace` gets the lines)
  /// µs a node polls for its next `advance` after answering one, and the master for the answers (docs/time.md,
  /// "Spinning"): -1 auto (kAutoSpinUs while every node on the clock and the master can have a CPU of their
  /// own, unpaced), 0 never
  int spin_us = -1;
  int cpus = 0;                   ///< the CPUs this process may run on (auto spin); 0: unknown, no auto spin
};

/// The spin window of `LockstepOptions::spin_us` = -1, when it applies.
inline constexpr int kAutoSpinUs = 2000;

/// What the clock master asks of the process it runs in.
struct LockstepHooks {
  std::function<bool()> ready;    ///< time stays put while this says false (empty: always ready)
  std::function<void()> step;     ///< the owner steps one period, from now() to now() + period
  std::function<void()> publish;  ///< the owner writes its outputs for the subscribers about to be advanced
  std::function<void()> settle;   ///< delivers what is in flight (Loop::settle)
  /// Calls LockstepCore::tick once, later: at once, or when the wall clock reaches `wall_due` (ns).
  std::function<void(std::optional<Nanos> wall_due)> schedule;
  std::function<Nanos()> wall_now;  ///< the wall clock (ns, CLOCK_MONOTONIC)
  /// The owner's links whose counts moved: {to = {key = sent}} (empty: the owner writes to nobody).
  std::function<wire::Value()> sent;
  /// Lets the samples counted in `expect` ({key = n}) into the owner's inputs, waiting for late ones: "" or
  /// why not (the writer named). Empty: the owner reads nothing.
  std::function<std::string(const wire::Value& expect)> take;
  /// The owner's outputs' digests ({out = [[port, count, digest, value]]}) for the trace.
  std::function<wire::Value()> digests;
  /// Sends what the owner kept back for these components (Endpoint::set_hold), just before their node's
  /// `advance` goes out: a node is sent its samples with its advance, one wake-up (empty: nothing kept back).
  std::function<void(const std::vector<std::string>& leaves)> release;
  /// One line of the trace (with trace on): "t kind who what"; "" at the end of each tick's lines.
  std::function<void(const std::string& line)> trace;
  /// The owner's input `in` lost its writer, at the tick the writer's node is lost or a new instance of the
  /// writer subscribes: a device input applies its safe value (zero velocity) until a new sample comes.
  std::function<void(const std::string& in)> writer_gone;
  /// The advances are out: poll for the answers for `us` µs before sleeping (Loop::spin_for; empty: never).
  std::function<void(int us)> spin;
};

/// The clock master's logic, without sockets or clocks of its own.
class LockstepCore {
 public:
  LockstepCore(LockstepOptions options, LockstepHooks hooks);
  LockstepCore(const LockstepCore&) = delete;
  LockstepCore& operator=(const LockstepCore&) = delete;

  /// `clock {name}`: subscribes `name` through `link`. A later subscription from the same `origin` (the
  /// connection it came on; never dereferenced) replaces this one.
  void subscribe(const void* origin, std::string name, std::shared_ptr<ClockLink> link, bool supervisor = false);
  /// `leaves {leaves}`: the components the node of `origin` hosts (its samples' counts go by them).
  void set_leaves(const void* origin, std::vector<std::string> leaves);
  /// `unclock {received, sent}`: a supervisor's last counts, said as it leaves.
  void counted(const void* origin, std::uint64_t received, std::uint64_t sent);
  /// `unclock`: the subscriber of `origin` leaves in order.
  void unsubscribe(const void* origin);
  /// `hold {at}`: time holds once it reaches `at` (ns).
  void hold_at(Nanos at) { hold_at_ = at; }
  /// A line of the trace at this tick ("W ..."; docs/time.md), when tracing.
  void note(const std::string& text) {
    if (opts_.trace) trace_lines_.push_back(std::to_string(now()) + " " + text);
  }
  /// `go`: time starts (or resumes) flowing. True if it was held.
  bool go();
  /// `hold`: time stops after the current tick.
  void hold() {
    running_ = false;
    hold_at_barrier_.reset();
  }
  /// `pace {speed}`: simulated seconds per wall second (<= 0: unpaced, as fast as the subscribers allow).
  /// The pacing is re-anchored at the current time, so a change never makes time jump or catch up.
  void set_speed(double speed);
  /// The pace: simulated seconds per wall second, 0 unpaced (LockstepOptions::realtime starts it at 1).
  double speed() const { return speed_; }
  /// `step {to}`: one tick then time holds (to_event false), or time runs to the end of the next tick that
  /// had a barrier (an event or a lost node: the supervisors' transitions) and holds there.
  void step(bool to_event);
  /// The tick the schedule hook was asked for is due.
  void tick();

  /// Lets the samples counted for the owner so far into its inputs (hook `take`), as at the start of a tick:
  /// "" or why not. The world calls it when it closes a recording, so that what was written at the last tick
  /// (time held) is in it too.
  std::string take_owner();
  /// Simulated time (ns).
  Nanos now() const { return steps_ * period_; }
  bool running() const { return running_; }
  /// True when component `leaf` is hosted by a node on this clock: the owner's samples to it may wait for
  /// that node's next `advance` (hook `release`), which is when it takes them in.
  bool clocked(const std::string& leaf);
  /// The clock's part of `status` (see the file comment).
  wire::Value status() const;
  /// The counts of `quiesce` so far: {events = {node = n}, lost = {leaf = n}}.
  wire::Value counts() const;
  /// Called once when `duration` is reached (time then holds).
  std::function<void()> on_duration;
  /// Called once, with why, when time cannot go on: a sample counted for the owner never came (time holds).
  std::function<void(const std::string&)> on_stuck;

 private:
  struct Subscriber {
    const void* origin = nullptr;
    std::string name;
    std::shared_ptr<ClockLink> link;
    bool supervisor = false;
    std::optional<Nanos> next;
    bool answered = false;                      // node: it answered an advance (its `next` is known)
    std::map<std::string, std::uint64_t> told;  // per link key into it: the count last sent in `expect`
    std::uint64_t events = 0;                   // node: events sent; supervisor: events sent up
    std::uint64_t received = 0;                 // supervisor: events received
    std::map<std::string, std::uint64_t> out;   // node, trace: samples per output at its last answer
    std::vector<std::string> leaves;            // node: the components it hosts (its answers say; else its name)
    std::map<std::string, std::uint64_t> evs;   // node: per leaf, the events count of its last answer
  };
  enum class Phase { Idle, Round, SyncBefore, Waves, SyncAfter };
  std::vector<std::uint64_t> due_at(Nanos t) const;
  void advance(const std::vector<std::uint64_t>& due, Nanos t);
  int spin_window() const;
  wire::Value expect_for(Subscriber& s);
  void answered(std::uint64_t id, Nanos t, const std::string& error, bool replied, const wire::Value& reply);
  void advanced(Nanos t);
  void took(Subscriber& s, Nanos t, const wire::Value& reply);
  void traced(Nanos t, const wire::Value& dig, std::map<std::string, std::uint64_t>& out);
  void add_sent(const wire::Value& sent);
  void hosts(Subscriber& s, std::vector<std::string> leaves);
  void forget(const std::string& leaf);
  void writer_gone(const std::string& leaf);
  void drop(std::uint64_t id, const std::string& why);
  void round_done(Nanos t);
  void sync_all(Nanos t, Phase next);
  void wave(Nanos t);
  void waved(Nanos t);
  std::uint64_t events_sent() const;
  void flush_trace();
  void after_tick();
  void schedule();
  Nanos paced(Nanos t) const;

  LockstepOptions opts_;
  LockstepHooks hooks_;
  Nanos period_, sync_, idle_, duration_;
  std::map<std::uint64_t, Subscriber> subs_;  // by subscription order
  std::set<std::string, std::less<>> clocked_;  // the components the node subscribers host (clocked())
  bool clocked_stale_ = true;                   // subs_ or their leaves changed since clocked_ was made
  std::uint64_t next_sub_ = 1;
  std::vector<std::string> dropped_;
  long steps_ = 0;
  bool running_ = false, scheduled_ = false, duration_hit_ = false, on_duration_pending_ = true;
  int waiting_ = 0;  // requests not yet answered (+1 while they are being sent)
  Phase phase_ = Phase::Idle;
  Nanos wall0_ = 0;  // the wall time at which simulated time would have been 0
  double wall_s_ = 0;  // wall time spent stepping and publishing while running
  double step_s_ = 0;  // of it, in the owner's step (the world's physics)
  double take_s_ = 0;  // of it, taking in (and waiting for) the samples counted for the owner
  double rounds_s_ = 0, barrier_s_ = 0;  // wall time in rounds, and in barriers (first sync to last)
  Nanos barrier0_ = 0;
  std::optional<Nanos> first_go_;  // the wall time at which time first started
  // Wall time of each round (advances sent -> last answer): what a simulated control period costs in real time.
  LatenessHistogram rounds_;
  Nanos round0_ = 0;
  std::uint64_t advances_ = 0;  // advances answered
  // Data counts: for each destination component, for each link into it, the samples sent by its writer's last
  // answer (the owner's after its publish).
  std::map<std::string, std::map<std::string, std::uint64_t>> sent_;
  std::map<std::string, std::uint64_t> owner_told_;
  // Events: sent by the nodes (done, aborted; the gone ones' too), nodes lost (no `unclock`), the supervisors'
  // counts of dropped ones; the total at the last barrier.
  std::uint64_t gone_events_ = 0, lost_ = 0, gone_received_ = 0, settled_ = 0;
  std::map<std::string, std::uint64_t> node_events_;  // by node name: its events so far (told in `quiesce`)
  std::map<std::string, std::uint64_t> lost_names_;  // by leaf: times its node was lost (told in `quiesce`)
  std::map<std::string, std::string> lost_why_;       // by leaf: why its node was last dropped (told in `quiesce`)
  std::vector<std::pair<std::uint64_t, std::uint64_t>> last_wave_;
  bool supervisor_lost_ = false;
  std::uint64_t barriers_ = 0, waves_ = 0;
  std::optional<Nanos> hold_at_;
  double speed_ = 0;  // simulated s per wall s (0: unpaced)
  std::optional<std::uint64_t> hold_at_barrier_;  // step to the next event: holds once barriers_ passes it
  std::vector<std::string> trace_lines_;  // this tick's, sorted before they are written
  std::map<std::string, std::uint64_t> owner_out_;
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

  /// A node's request hook (Node::on_request): clock, go, hold, pace, step, status. False for any other type.
  bool handle(const std::shared_ptr<Channel>& ch, const wire::Message& m);
  /// Starts time flowing (as `go`).
  void go();
  /// Simulated time (ns).
  Nanos now() const { return core_.now(); }
  /// The clock's part of `status`.
  wire::Value status() const { return core_.status(); }
  /// LockstepCore::take_owner.
  std::string take_owner() { return core_.take_owner(); }
  /// LockstepCore::note.
  void note(const std::string& text) { core_.note(text); }
  /// LockstepCore::clocked.
  bool clocked(const std::string& leaf) { return core_.clocked(leaf); }
  /// Called once when the duration is reached (time then holds).
  std::function<void()> on_duration;
  /// Called once, with why, when the channel that said `go` (the master: a run's root) has closed: time then
  /// holds. A world whose master died would otherwise run on alone at full speed (the owner exits).
  std::function<void(const std::string&)> on_master_lost;
  /// LockstepCore::on_stuck.
  std::function<void(const std::string&)> on_stuck;

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
