#pragma once
// host/rt: the real-time side of a node; no Asio, no Lua, nothing that allocates or locks after start-up.
//
// RtThread: the real-time thread of a node (docs/time.md, "Real time"). It runs periodic tasks (a controller's
// MainCalc) on a thread of its own, woken by clock_nanosleep(TIMER_ABSTIME) on CLOCK_MONOTONIC at each task's
// absolute deadline: deadline k is start + k * period, never "now + period", so nothing drifts. A task that
// wakes or ends so late that whole periods went by skips them (counted as `missed`): they are never run in a
// burst to catch up. An execution that ends past its next deadline is an overrun.
//
// Tasks are added before start(); the thread then owns them. Per task: the wake latency (how late it ran
// after its deadline) and the execution time, in RtHistograms any thread may read while it runs, and the
// counts of runs, overruns and missed periods (relaxed atomics). start() applies the RtConfig on the new
// thread (scheduler, priority, CPU, pre-faulted stack: host/rt/setup.h) and returns its warnings; without the
// privilege the thread runs under the default scheduler, never fails to start.
//
// Only on the wall clock: in simulated (lock-step) time a node has no RtThread and nothing changes.
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "host/rt/histogram.h"
#include "host/rt/setup.h"

namespace dca::rt {

/// One task's figures, as counted so far.
struct RtTaskStats {
  std::string name;
  std::int64_t period_ns = 0;
  std::uint64_t runs = 0, overruns = 0, missed = 0;
  RtSummary wake;  ///< how late each run started after its deadline
  RtSummary exec;  ///< how long each run took
};

class RtThread {
 public:
  explicit RtThread(RtConfig config = {});
  ~RtThread();  ///< stops and joins
  RtThread(const RtThread&) = delete;
  RtThread& operator=(const RtThread&) = delete;

  /// Adds a task run every `period_ns` (> 0), first at the first multiple of its period after start(). Before
  /// start() only. `fn` must not allocate, lock or block (host/rt/contract.h measures it).
  void add(std::string name, std::int64_t period_ns, std::function<void()> fn);
  /// Called on the thread once per wake, before the due tasks (e.g. to drain the rings from the I/O thread).
  void on_wake(std::function<void()> fn);
  /// Starts the thread; returns the warnings of its set-up ("" when the RtConfig was applied in full).
  std::string start();
  /// Stops the thread at its next wake and joins it (idempotent).
  void stop();
  bool running() const { return thread_.joinable(); }
  /// Every task's figures (any thread).
  std::vector<RtTaskStats> stats() const;
  /// The wake histograms of task `i` (any thread), for a benchmark's own quantiles.
  const RtHistogram& wake_histogram(std::size_t i) const;

  struct Task;

 private:
  void run();
  RtConfig config_;
  std::vector<std::unique_ptr<Task>> tasks_;
  std::function<void()> on_wake_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace dca::rt
