#pragma once
// The process's event loop: one Boost.Asio io_context, run by one thread (the caller of run()).
// Include this header before any other Asio header: it includes Asio's core with GCC 12's false-positive
// -Wnull-dereference (in Asio's scheduler, inlined at -O3) silenced, which -Werror builds need.
// Every dca component of a process (channels, listeners, the daemon, the Executer, timers) runs its handlers
// on this io_context, so they need no locks.
#pragma GCC diagnostic push  // Asio's scheduler trips GCC 12's -Wnull-dereference when inlined at -O3
#pragma GCC diagnostic ignored "-Wnull-dereference"
#include <boost/asio/io_context.hpp>
#include <boost/asio/posix/stream_descriptor.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/signal_set.hpp>
#include <boost/asio/steady_timer.hpp>
#pragma GCC diagnostic pop
#include <chrono>
#include <cstdint>
#include <functional>
#include <initializer_list>
#include <map>
#include <memory>

namespace dca {

/// The process's io_context with run/stop helpers and signal handling.
class Loop {
 public:
  Loop();
  ~Loop();
  Loop(const Loop&) = delete;
  Loop& operator=(const Loop&) = delete;

  /// The io_context every component of this process is built on.
  boost::asio::io_context& io() { return io_; }

  /// Runs handlers until stop() is called or no work is left. Returns the number of handlers run.
  std::size_t run();
  /// Runs handlers until `done()` returns true (checked before waiting and after each handler) or `timeout`
  /// has passed. Returns true when `done()` became true. Does not consume a pending stop().
  bool run_until(const std::function<bool()>& done, std::chrono::nanoseconds timeout);
  /// Runs handlers for `duration` (or until stop()).
  void run_for(std::chrono::nanoseconds duration);
  /// Runs every handler that is ready now, and those they make ready, until none is (at most `max_rounds`
  /// rounds of io_context::poll). Safe from inside a handler of this loop (Asio supports nested polls on a
  /// one-thread io_context). Lock-step uses it to drain data sockets before a tick and to flush writes after
  /// it. Returns the number of handlers run.
  std::size_t settle(int max_rounds = 1000);
  /// Lets spin_for() work in this loop's run() (a node or world on simulated time; else run() is io_context::run).
  void allow_spin() { may_spin_ = true; }
  /// With allow_spin(): for `window` from now, run() polls instead of sleeping, yielding the CPU between polls
  /// (sched_yield), so a message arriving meanwhile is taken without a wake-up. Lock-step uses it between a
  /// node's answer and its next `advance` (docs/time.md, "Spinning"). Each call extends the window.
  void spin_for(std::chrono::microseconds window);
  /// The polls run() made in spin windows so far.
  std::uint64_t spun() const { return spun_; }
  /// Makes run() return after the current handler (safe from any thread and from signal handlers' callbacks).
  void stop();
  /// True once stop() was called and run() has not been entered since.
  bool stopped() const { return io_.stopped(); }

  /// Calls `fn(signal)` from the loop each time one of `signals` (e.g. SIGTERM, SIGINT) arrives. Replaces any
  /// earlier handler. The signals are handled only while the Loop lives.
  void on_signals(std::initializer_list<int> signals, std::function<void(int)> fn);
  /// Calls `fn()` from the loop each time `signal` arrives (e.g. SIGUSR2), besides on_signals' handler; replaces
  /// an earlier one for that signal. The signal is handled only while the Loop lives.
  void on_signal(int signal, std::function<void()> fn);

 private:
  void wait_signal();
  void wait_extra(boost::asio::signal_set* set, int signal);
  boost::asio::io_context io_{1};
  bool may_spin_ = false;
  std::chrono::steady_clock::time_point spin_until_{};  // spin_for's window (epoch: none)
  std::uint64_t spun_ = 0;
  std::map<int, std::pair<std::unique_ptr<boost::asio::signal_set>, std::function<void()>>> extra_;
  std::unique_ptr<boost::asio::signal_set> signals_;
  std::function<void(int)> on_signal_;
};

}  // namespace dca
