#pragma once
// A service under systemd (docs/deploy.md, "The unit"): the sd_notify protocol spoken without libsystemd (one
// datagram of "KEY=VALUE" lines on the Unix socket named by $NOTIFY_SOCKET, sd_notify(3)), the watchdog's period
// from $WATCHDOG_USEC, and log lines for journald (a "<N>" syslog priority before each line when stderr is the
// journal's stream, $JOURNAL_STREAM; no time stamps of our own in any case: journald and terminals add theirs).
// Nothing here throws; without a service manager every call is a no-op, so a daemon started by hand is unchanged.
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>

#include "host/loop.h"

namespace dca::systemd {

/// syslog's priorities, as journald reads them from a "<N>" prefix.
enum class Priority { err = 3, warning = 4, notice = 5, info = 6, debug = 7 };

/// True when stderr is the journal's stream: $JOURNAL_STREAM ("DEVICE:INODE") names stderr's file (a child that
/// inherited the variable with another stderr, such as a node whose stderr is its daemon's pipe, gets false).
/// Read once, at the first call.
bool stderr_is_journal();

/// Writes `line` and a newline to stderr in one write, after "<N>" when stderr is the journal.
void log_line(Priority p, const std::string& line);

/// printf-style log_line.
void log(Priority p, const char* format, ...) __attribute__((format(printf, 2, 3)));

/// The service manager's side of one service process. Construct it once, early: it takes $NOTIFY_SOCKET,
/// $WATCHDOG_USEC and $WATCHDOG_PID out of the environment, so that the processes this one spawns do not
/// inherit them (only the main process may notify).
class Notifier {
 public:
  Notifier();
  ~Notifier();
  Notifier(const Notifier&) = delete;
  Notifier& operator=(const Notifier&) = delete;

  /// True when a service manager listens ($NOTIFY_SOCKET was set).
  bool enabled() const { return !socket_.empty(); }
  /// The watchdog period the manager asked for (0 when none, or when $WATCHDOG_PID names another process).
  std::chrono::microseconds watchdog_period() const { return watchdog_; }

  /// Sends `state` (newline-separated KEY=VALUE assignments, e.g. "READY=1\nSTATUS=listening"): true when
  /// sent; false when there is no manager, or with *error when the datagram could not be sent.
  bool notify(const std::string& state, std::string* error = nullptr) const;

  /// READY=1 with a STATUS line, then WATCHDOG=1 from `io`'s loop at half the watchdog period until stopping()
  /// (or this object's end): a loop that hangs stops feeding the watchdog, and the manager restarts the service.
  /// A datagram that cannot be sent is said once on stderr.
  void ready(boost::asio::io_context& io, const std::string& status);
  /// STOPPING=1 with a STATUS line; the watchdog is no longer fed.
  void stopping(const std::string& status);
  /// How many WATCHDOG=1 were sent so far.
  std::uint64_t watchdogs() const { return watchdogs_; }

 private:
  void arm_watchdog();
  void send_or_say(const std::string& state);

  std::string socket_;
  std::chrono::microseconds watchdog_{0};
  std::unique_ptr<boost::asio::steady_timer> timer_;
  std::uint64_t watchdogs_ = 0;
  bool said_error_ = false;
};

}  // namespace dca::systemd
