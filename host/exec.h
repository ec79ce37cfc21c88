#pragma once
// The Executer: starts allow-listed programs with an argv array (posix_spawn, never a shell), each child in its
// own process group; reports each child's exit code or signal; kills on request; and when it stops (or is
// destroyed) kills every child's process group and reaps it, so no zombie and no orphan is left.
// Children are watched with pidfds on the io_context: no SIGCHLD handler, and processes the Executer did not
// start are never reaped by it.
#include <sys/types.h>

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "host/loop.h"  // Asio, included the way GCC 12 -Werror accepts

namespace dca {

/// Which programs the Executer may start.
class AllowList {
 public:
  /// The default: only the dca executable itself (/proc/self/exe) with first argument node, supervise or sim.
  static AllowList defaults();

  /// Allows `program` (an absolute path, or "dca" for this executable) when its first argument is one of
  /// `first_args` (any argument when empty).
  void allow(const std::string& program, std::vector<std::string> first_args = {});

  /// The path to execute for `argv`, or nullopt with *error ("not allowed: ..."). argv[0] is "dca" (this
  /// executable) or an absolute path; it is compared with the allowed programs after resolving symlinks.
  std::optional<std::string> resolve(const std::vector<std::string>& argv, std::string* error) const;

 private:
  struct Rule {
    std::string program;  // resolved path
    std::vector<std::string> first_args;
  };
  std::vector<Rule> rules_;
};

/// How a child ended.
struct ExitStatus {
  pid_t pid = 0;
  bool exited = false;  ///< true: ended by exit(code); false: killed by `signal`
  int code = 0;         ///< exit code (when exited)
  int signal = 0;       ///< signal number (when killed)
  bool core = false;    ///< a core was dumped
  /// "SIGSEGV" etc. ("" when exited).
  std::string signal_name() const;
  /// "exit code 3" or "killed by SIGSEGV".
  std::string str() const;
};

/// "SIGSEGV" for SIGSEGV; "SIG<n>" for a number with no name.
std::string signal_name(int sig);
/// The number of a signal given as "SIGKILL", "KILL", "kill" or "9"; 0 when unknown.
int signal_number(const std::string& name);

/// Starts and watches children. Runs on one io_context.
class Executer {
 public:
  using ChildId = std::uint64_t;
  /// Called once per child, from the loop, when it ends.
  using ExitFn = std::function<void(ChildId, const ExitStatus&)>;
  /// Called from the loop with each line a child writes to its stderr (without the newline; a line over
  /// kMaxLine bytes comes in pieces of that size). Every line it wrote comes before its ExitFn.
  using LineFn = std::function<void(ChildId, const std::string& line)>;
  static constexpr std::size_t kMaxLine = 4096;

  Executer(boost::asio::io_context& io, AllowList allow);
  /// Stops (see stop_all) with a short grace period.
  ~Executer();
  Executer(const Executer&) = delete;
  Executer& operator=(const Executer&) = delete;

  /// A started child.
  struct Child {
    ChildId id = 0;
    pid_t pid = 0;
  };
  /// Starts argv (checked against the allow-list) in its own process group, stdin from /dev/null, stdout and
  /// stderr inherited, no other descriptor inherited. nullopt with *error when refused or when it cannot start.
  /// With `on_stderr`, its stderr is a pipe read on the loop instead, line by line: reading never stops, so the
  /// child never waits on it longer than the loop's turn takes (the pipe holds up to 1 MiB meanwhile).
  std::optional<Child> spawn(const std::vector<std::string>& argv, ExitFn on_exit, std::string* error,
                             LineFn on_stderr = nullptr);
  /// Sends `signal` to the child's process group. False with *error for an unknown (or already ended) child.
  bool kill(ChildId child, int signal, std::string* error);
  /// Stops every child: SIGTERM to each process group, up to `grace` for them to end, then SIGKILL; reaps all.
  /// Blocks for at most `grace` plus the time SIGKILL takes. on_exit callbacks are not called. Idempotent.
  void stop_all(std::chrono::milliseconds grace);

  /// The running children (id -> pid).
  std::map<ChildId, pid_t> children() const;
  std::size_t running() const { return children_.size(); }
  /// Makes every spawn fail with "the executer is stopping" from now on.
  void refuse_new() { refusing_ = true; }

 private:
  struct Watch;
  void reaped(ChildId id);
  void read_stderr(const std::shared_ptr<Watch>& w);
  void stderr_ended(const std::shared_ptr<Watch>& w);
  void exit_now(const std::shared_ptr<Watch>& w, const ExitStatus& s);
  boost::asio::io_context& io_;
  AllowList allow_;
  std::map<ChildId, std::shared_ptr<Watch>> children_;
  std::map<ChildId, std::shared_ptr<Watch>> draining_;  // reaped, exit held until their stderr pipe ends
  ChildId next_id_ = 1;
  bool refusing_ = false;
};

}  // namespace dca
