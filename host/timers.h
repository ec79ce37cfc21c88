#pragma once
// The TimerServer: periodic and one-shot timers for every controller of a process, on one clock
// (docs/time.md; SEMANTICS.md §12 for the Timer and Deadline controllers built on it).
//
// Two clocks:
//   - Wall: CLOCK_MONOTONIC. Timers are absolute deadlines on one timerfd (TFD_TIMER_ABSTIME) registered with
//     the process's io_context, so timer callbacks run on the same thread as the data plane and nothing needs
//     a lock. A periodic timer's next deadline is the previous deadline plus the period (no drift); when a
//     callback overran whole periods they are skipped and counted (`missed`). The constructor minimises the
//     calling thread's timer slack (prctl PR_SET_TIMERSLACK, 1 ns): construct the TimerServer on the thread
//     that runs the io_context (the control-loop thread), or call minimise_timer_slack() there.
//   - Simulated: time stands still until a master advances it. Nothing fires on its own.
//
// Simulated time and its master (the simulator). The master owns time; each process with controllers
// has a TimerServer on a Simulated clock and obeys the master in lock-step:
//   1. the master asks every TimerServer for next_deadline() (a node answers this in its `advance` reply);
//   2. it picks the next tick t (the smallest of those and its own integration step) and calls advance_to(t)
//      on every TimerServer (a node does this on `advance {t}` from its control channel);
//   3. advance_to(t) runs, in order, every timer due at or before t — each callback (a controller's MainCalc)
//      runs to completion before the next — then sets now() = t and returns the next deadline;
//   4. only when every TimerServer has returned (every node has replied) does the master move on.
// So the clock moves to the next tick only when every controller due at the current tick has finished its
// MainCalc, and the order of callbacks at one tick is fixed (deadline, then creation order): every run is the
// same. In one process the master simply calls advance_to()/step() itself (see tests/host/timers_test.cpp).
//
// Lateness: for every timer, how late each callback started (now - deadline when it ran), as count, p50, p99
// and max (a histogram, no allocation per tick); the node reports them to its supervisor (`stats {}`).
//
// Intervals (the periods achieved): for every periodic timer, the time between consecutive callbacks (for a
// controller, between consecutive MainCalc calls), both on the server's clock (simulated time on a Simulated
// clock, where it is the period unless ticks were skipped) and on the wall clock (CLOCK_MONOTONIC: what a
// period costs in real time; in a lock-stepped run paced to the wall clock, the real control period). They
// are kept per (timer name, period), so a controller that is stopped and run again adds to the same figures
// (the gap between its runs is not an interval); two IntervalHistograms each, made when the timer is made,
// never per tick. At most kMaxIntervalKeys distinct (name, period) pairs are kept per server.
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <limits>
#include <string>
#include <vector>

#include "host/loop.h"

namespace dca {

/// Nanoseconds on a Clock (since its epoch: boot for the wall clock, 0 for a simulated clock).
using Nanos = std::int64_t;

/// A time past any run (about 292 years): long times saturate to it, and a timer due at it never fires.
inline constexpr Nanos kNever = std::numeric_limits<Nanos>::max();

/// Seconds -> Nanos (rounded to the nearest nanosecond). Saturates: +inf and anything past kNever give kNever
/// (-inf and below: -kNever); NaN gives 0 (parameters are checked before they get here).
Nanos from_seconds(double s);
/// Nanos -> seconds.
double to_seconds(Nanos n);

/// CLOCK_MONOTONIC now.
Nanos monotonic_now();

/// Sets the calling thread's timer slack to 1 ns (prctl PR_SET_TIMERSLACK). False if the kernel refused.
bool minimise_timer_slack();

/// Which clock a TimerServer runs on.
enum class ClockKind : std::uint8_t { Wall, Simulated };

/// "wall" or "sim".
const char* to_string(ClockKind k);

/// A lateness histogram: 1 µs buckets below 1 ms, 100 µs buckets to 100 ms, one overflow bucket; exact max.
class LatenessHistogram {
 public:
  /// Records one lateness (negative values count as 0).
  void record(Nanos late);
  /// Number of records.
  std::uint64_t count() const { return count_; }
  /// The q-quantile (0..1) in nanoseconds: the upper edge of its bucket (never above max()).
  Nanos quantile(double q) const;
  /// The largest lateness recorded.
  Nanos max() const { return max_; }

 private:
  static constexpr int kFine = 1000;   // 1 µs buckets, [0, 1 ms)
  static constexpr int kCoarse = 999;  // 100 µs buckets, [1 ms, 100.9 ms)
  std::uint32_t buckets_[kFine + kCoarse + 1] = {};
  std::uint64_t count_ = 0;
  Nanos max_ = 0;
};

/// A histogram of non-negative durations in nanoseconds, log-linear: exact below 1024 ns, then 512 buckets per
/// power of two (a bucket is at most 1/512 of its value wide: 1.024 µs around 1 ms, 16 µs around 10 ms), up
/// to 2^37 ns (137 s; longer ones share the last bucket). Exact count, min, max and mean; about 59 KB, no
/// allocation when recording.
class IntervalHistogram {
 public:
  /// Records one duration (negative values count as 0).
  void record(Nanos v);
  /// Adds every record of `other`.
  void merge(const IntervalHistogram& other);
  /// Number of records.
  std::uint64_t count() const { return count_; }
  /// The q-quantile (0..1): the upper edge of its bucket, clamped to [min(), max()] (so exact when every
  /// record is the same; the last bucket's is max()); 0 when empty.
  Nanos quantile(double q) const;
  /// The smallest record (0 when empty).
  Nanos min() const { return count_ ? min_ : 0; }
  /// The largest record.
  Nanos max() const { return max_; }
  /// The mean of the records (0 when empty).
  double mean() const { return count_ ? sum_ / static_cast<double>(count_) : 0.0; }

 private:
  static constexpr int kSubBits = 9;                 // 512 sub-buckets per power of two
  static constexpr int kSub = 1 << kSubBits;
  static constexpr int kTopBit = 37;                 // values up to 2^37 ns
  static constexpr int kBuckets = 2 * kSub + (kTopBit - kSubBits - 1) * kSub;
  static std::size_t index(Nanos v);
  static Nanos upper(std::size_t i);  // the largest value of bucket i
  std::uint32_t buckets_[kBuckets] = {};
  std::uint64_t count_ = 0;
  Nanos min_ = 0, max_ = 0;
  double sum_ = 0;
};

/// An IntervalHistogram's figures, in microseconds.
struct IntervalSummary {
  std::uint64_t n = 0;  ///< intervals recorded
  double p50_us = 0, p99_us = 0, p999_us = 0, max_us = 0, min_us = 0, mean_us = 0;
};

/// The periods achieved by the periodic timers of one (name, period): intervals between consecutive callbacks.
struct IntervalStats {
  std::string name;
  Nanos period = 0;
  IntervalSummary clock;  ///< on the server's clock (simulated time on a Simulated clock)
  IntervalSummary wall;   ///< on the wall clock (CLOCK_MONOTONIC)
};

/// An IntervalHistogram's figures.
IntervalSummary summarize(const IntervalHistogram& h);

/// One timer's statistics (what the supervisor sees).
struct TimerStats {
  std::uint64_t id = 0;
  std::string name;
  Nanos period = 0;          ///< 0 for one-shot timers
  bool active = false;       ///< false once cancelled or (one-shot) fired
  std::uint64_t count = 0;   ///< callbacks run
  std::uint64_t missed = 0;  ///< whole periods skipped because a callback started too late
  double p50_us = 0, p99_us = 0, max_us = 0;  ///< lateness
};

/// Periodic and one-shot timers on one clock. Not thread-safe: use it from its io_context's thread.
class TimerServer {
 public:
  /// A timer's handle.
  using Id = std::uint64_t;

  /// A TimerServer on `kind` of clock. Wall: creates its timerfd on `io` and minimises the calling thread's
  /// timer slack. Throws std::system_error if the timerfd cannot be made.
  explicit TimerServer(boost::asio::io_context& io, ClockKind kind = ClockKind::Wall);
  ~TimerServer();
  TimerServer(const TimerServer&) = delete;
  TimerServer& operator=(const TimerServer&) = delete;

  /// Calls `fn` every `period` ns, first at now() + `period` (or at the absolute time `first` when >= 0). With
  /// set_aligned(true), the first deadline is instead the next multiple of `period` after now().
  Id every(Nanos period, std::function<void()> fn, std::string name = "", Nanos first = -1);
  /// Calls `fn` once, `delay` ns from now().
  Id after(Nanos delay, std::function<void()> fn, std::string name = "");
  /// Cancels a timer (safe from inside any callback, including its own). False if unknown or already done.
  bool cancel(Id id);

  /// The clock's current time.
  Nanos now() const;
  /// The clock's kind.
  ClockKind kind() const { return kind_; }
  /// Aligned periodic timers: every() without `first` starts at the next multiple of its period, so all
  /// timers of one period tick together in every process of a lock-stepped system (a node on simulated time
  /// sets this; the master then wakes it once per tick, not once per timer).
  void set_aligned(bool aligned) { aligned_ = aligned; }
  /// Inside a timer callback: the deadline it was due at (its tick time); -1 outside callbacks.
  Nanos current_deadline() const;
  /// Wall clock only: the timers are run by a thread of the caller's (a node's real-time thread: host/node_rt.h)
  /// calling run_due(), never by the timerfd. Call before the first timer; from then on only that thread (or
  /// any, while it is stopped) uses this server.
  void set_driven();
  /// Driven: runs every timer due by the wall clock now, as the timerfd would (late periods skipped and counted,
  /// never bunched). Returns the number of callbacks run.
  std::size_t run_due();


  /// Statistics of every timer still known (active ones, and the last finished ones).
  std::vector<TimerStats> stats() const;
  /// Statistics of one timer.
  std::optional<TimerStats> stats(Id id) const;
  /// The periods achieved by the periodic timers, per (name, period), in the order first made.
  std::vector<IntervalStats> interval_stats() const;
  /// The most distinct (name, period) pairs whose intervals are kept; timers beyond are not measured.
  static constexpr std::size_t kMaxIntervalKeys = 64;

  /// The earliest deadline among active timers, if any.
  std::optional<Nanos> next_deadline() const;
  /// Simulated clock only: runs every timer due at or before `t` in (deadline, creation) order, each with
  /// now() equal to its deadline, then sets now() = t. Returns the number of callbacks run. Throws
  /// std::logic_error on a wall clock or when `t` is before now().
  std::size_t advance_to(Nanos t);
  /// Simulated clock only: advance_to(next_deadline()); 0 when no timer is active.
  std::size_t step();

  /// Called just before every timer callback with its timer's name, and just after it with nullptr (a shared
  /// node notes whose code runs: host/node.h, the crash note).
  std::function<void(const std::string* name)> on_enter;
  /// Called after every timer callback with (timer name, deadline): a trace for tests and the simulator.
  std::function<void(const std::string& name, Nanos deadline)> on_fire;
  /// Driven servers: called after every callback of a timer with its name, deadline, period (0: one-shot) and
  /// the wall-clock times it started and ended (the real-time thread's statistics: host/node_rt.h).
  std::function<void(const std::string& name, Nanos deadline, Nanos period, Nanos start, Nanos end)> on_ran;

  struct Impl;

 private:
  ClockKind kind_;
  bool aligned_ = false;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dca
