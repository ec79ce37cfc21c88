#pragma once
// Starting a child process from an argv (posix_spawn: never a shell), and the child's side of "no orphans".
//
// Every child started here is told its parent's pid in the environment (DCA_PARENT_PID). A dca process calls
// die_with_parent() first thing in main: when the variable is there, it asks the kernel for SIGTERM when its
// parent dies (PR_SET_PDEATHSIG), then checks that the parent is still the one named, so a parent that died
// between the spawn and that call is caught too. The variable is removed at once, so it reaches only the
// process it was meant for: a grandchild started through a shell or another program does not inherit it.
// SIGTERM is each dca process's own orderly stop: a daemon stops its children (LIFO), a node zeroes its
// actuators, a world stops. So whatever kills `dca run`, even SIGKILL or the OOM killer, the daemons it started
// stop, and with them everything they started.
//
// PR_SET_PDEATHSIG fires when the *thread* that spawned the child ends: spawn from the thread that lives as long
// as the process (every dca process spawns from its main thread, which runs its loop).
#include <sys/types.h>

#include <optional>
#include <string>
#include <vector>

namespace dca {

struct SpawnOptions {
  std::string stdin_path = "/dev/null";  ///< opened read-only as fd 0
  std::string stdout_path;               ///< "" keeps the parent's fd 1; else opened (created 0600, truncated)
  bool stderr_to_stdout = true;          ///< fd 2 = fd 1 (only with stdout_path)
  int stderr_fd = -1;                    ///< >= 0: fd 2 is a copy of this descriptor (a pipe's write end)
  bool new_session = false;              ///< setsid: a Ctrl-C at the terminal does not reach the child
  bool new_group = false;                ///< its own process group, led by the child
  bool parent_death = true;              ///< pass DCA_PARENT_PID (see die_with_parent)
};

/// Starts `path` with `argv` (argv[0] included), every other descriptor closed and signals at their defaults.
/// The child's pid, or nullopt with *error ("cannot start PATH: reason"; an argument holding a NUL byte is
/// refused: it cannot be passed intact).
std::optional<pid_t> spawn_process(const std::string& path, const std::vector<std::string>& argv,
                                   const SpawnOptions& opts, std::string* error);

/// The child's side: with DCA_PARENT_PID in the environment, SIGTERM on the parent's death (and at once if
/// the parent is already gone); the variable is removed. Without it: nothing.
void die_with_parent();

}  // namespace dca
