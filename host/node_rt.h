#pragma once
// RtHost: a node's real-time thread and the leaves it runs (docs/time.md, "Real time"). A node on the wall clock
// with an rt setting (`dca node --rt-priority P --rt-cpu C`, or `rt { }` in the .dca) makes its leaves' components
// on timers() and hands them to adopt(); from then on:
//   - their timers (a periodic controller's MainCalc, a one-shot) run on the real-time thread, woken by
//     clock_nanosleep(TIMER_ABSTIME) on CLOCK_MONOTONIC at each deadline; periods that went by are skipped and
//     counted, never run in a burst (TimerServer::set_driven);
//   - their ports are the thread's: a trigger and an in-process link between two of them (link()) run there too;
//   - the endpoint, the control plane, taps and `read` see a mirror of each leaf's ports on the I/O thread.
//     Samples cross between a port and its mirror through SpscRings (host/rt/spsc_ring.h): a sample written by
//     the leaf goes to the mirror's links (sockets, taps), a sample delivered to the mirror goes to the leaf's
//     input at the thread's next wake. Neither side ever takes a lock or waits for the other;
//   - configure/start/halt/set_parameter (init, run, stop, set_param) go to the thread as commands on a ring and
//     are answered on the I/O thread; DONE and ABORTED come back the same way;
//   - per leaf, the wake latency (how late each run started after its deadline) and the execution time, in
//     lock-free histograms, and the counts of runs, overruns and missed periods: stats().
// The thread wakes at least every kIdle to take commands and samples. Adding or forgetting a leaf stops the thread
// and starts it again (between two ticks). Without the privilege the thread runs under the default scheduler, on
// its own still, with one warning (host/rt/setup.h). Never on simulated time: a lock-stepped node has no RtHost.
// A leaf's Input::request() on the thread asks the mirror's pull connections, whose answer crosses back like a
// pushed sample. A sample bigger than kMaxSample bytes is dropped and counted (dropped()).
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <dca/component.h>

#include "host/loop.h"  // first of Asio (host/loop.h says why)
#include "host/port.h"
#include "host/rt/contract.h"
#include "host/rt/histogram.h"
#include "host/rt/setup.h"
#include "host/timers.h"

namespace dca {

/// One leaf's figures on the real-time thread (lock-free: read from the I/O thread while it runs).
struct RtLeafStats {
  std::uint64_t runs = 0, overruns = 0, missed = 0;
  Nanos period = 0;    ///< of its last run (0: a one-shot or none yet)
  rt::RtSummary wake;  ///< how late each run started after its deadline
  rt::RtSummary exec;  ///< how long each run took
  /// Their histograms' buckets that hold runs: (upper edge in ns, count), in order (RtHistogram::buckets).
  std::vector<std::pair<std::int64_t, std::uint64_t>> wake_buckets, exec_buckets;
};

class RtHost {
 public:
  /// The largest sample carried between a port and its mirror.
  static constexpr std::size_t kMaxSample = 1000;
  /// The longest the thread sleeps without a deadline: the latency of a command or a sample from the I/O thread.
  static constexpr Nanos kIdle = 2'000'000;

  /// On the node's io_context (its thread is the I/O thread); the thread is started by start().
  RtHost(boost::asio::io_context& io, rt::RtConfig config);
  ~RtHost();  ///< stops the thread
  RtHost(const RtHost&) = delete;
  RtHost& operator=(const RtHost&) = delete;

  /// The thread's TimerServer (driven by it): make the components on this one.
  TimerServer& timers();
  /// Runs `c` on the thread from now on; returns the mirror the endpoint and the control plane use. `on_event`
  /// gets its DONE/ABORTED on the I/O thread.
  PortSet& adopt(Component& c, std::function<void(const ComponentEvent&)> on_event);
  /// Takes `c` back (halted on the calling thread, its outputs' last samples sent to the mirror): before it is
  /// destroyed. Returns its mirror, to be destroyed once the endpoint has let go of it.
  std::unique_ptr<PortSet> forget(Component& c);

  enum class Op : std::uint8_t { Configure, Start, Halt, SetParameter };
  using Reply = std::function<void(const std::string& error)>;
  /// A life-cycle operation on `c`, run by the thread between two ticks (Start: a = the initial value's msgpack;
  /// SetParameter: a = name, b = text); `done(error)` on the I/O thread ("" when it went well).
  void request(Component& c, Op op, std::string a, std::string b, Reply done);

  /// An in-process push link between two adopted leaves, kept on the thread: `from`'s output `out` hands each
  /// sample to `to`'s input `in` there, while active (inactive at first, in connection set `set`). False, with
  /// *error, when a port is unknown or the types misfit. Pauses the thread.
  bool link(Component& from, const std::string& out, Component& to, const std::string& in, const std::string& set,
            std::uint32_t queue, std::string* error);
  /// Switches the links of `from` in `set` (a flag each, read by the thread: no pause). Returns how many.
  std::size_t activate(const std::string& set, const Component& from, bool active);
  /// Removes the links of `set` (pauses the thread).
  void unlink(const std::string& set);
  struct LinkInfo {
    std::string from, out, to, in, set;
    bool active = false;
    std::uint64_t sent = 0, skipped = 0;
  };
  /// The links from `from` (any thread: their counters are atomics; the list changes only on this one).
  std::vector<LinkInfo> links(const Component& from) const;

  /// Starts the thread; the warnings of its set-up the first time ("" when the RtConfig was applied in full).
  std::string start();
  /// Stops the thread at its next wake and joins it (idempotent).
  void stop();
  bool running() const;
  /// The thread's kernel id (gettid), 0 before it ran.
  long thread_id() const;
  /// `c`'s figures; nothing when it is not adopted.
  std::optional<RtLeafStats> stats(const Component& c) const;
  /// What the thread counted since it started (host/rt/contract.h: allocations and locks when the hooks are
  /// linked, page faults always), as of its last wake.
  rt::contract::Counts contract() const;
  /// Samples not carried: a ring full, or bigger than kMaxSample.
  std::uint64_t dropped() const;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace dca
