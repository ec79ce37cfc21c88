#include "host/spawn.h"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/prctl.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <string_view>

extern char** environ;

namespace dca {
namespace {

constexpr std::string_view kParentVar = "DCA_PARENT_PID=";

// This process's environment without DCA_PARENT_PID, then DCA_PARENT_PID=<this pid> when asked. `store` owns
// the added string.
std::vector<char*> child_environment(bool parent_death, std::string& store) {
  std::vector<char*> env;
  for (char** e = environ; e != nullptr && *e != nullptr; ++e)
    if (std::string_view(*e).substr(0, kParentVar.size()) != kParentVar) env.push_back(*e);
  if (parent_death) {
    store = std::string(kParentVar) + std::to_string(::getpid());
    env.push_back(store.data());
  }
  env.push_back(nullptr);
  return env;
}

}  // namespace

std::optional<pid_t> spawn_process(const std::string& path, const std::vector<std::string>& argv,
                                   const SpawnOptions& opts, std::string* error) {
  const auto fail = [&](std::string why) -> std::optional<pid_t> {
    if (error != nullptr) *error = "cannot start " + path + ": " + std::move(why);
    return std::nullopt;
  };
  if (argv.empty()) return fail("no argv");
  std::vector<char*> args;
  for (const auto& a : argv) {
    if (a.find('\0') != std::string::npos) return fail("an argument holds a NUL byte");
    args.push_back(const_cast<char*>(a.c_str()));
  }
  args.push_back(nullptr);
  std::string parent_var;
  std::vector<char*> env = child_environment(opts.parent_death, parent_var);

  posix_spawnattr_t attr;
  posix_spawn_file_actions_t fa;
  ::posix_spawnattr_init(&attr);
  ::posix_spawn_file_actions_init(&fa);
  sigset_t none, all;
  sigemptyset(&none);
  sigfillset(&all);
  short flags = POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETSIGDEF;
  if (opts.new_session) flags |= POSIX_SPAWN_SETSID;
  else if (opts.new_group) flags |= POSIX_SPAWN_SETPGROUP;
  ::posix_spawnattr_setflags(&attr, flags);
  ::posix_spawnattr_setpgroup(&attr, 0);
  ::posix_spawnattr_setsigmask(&attr, &none);
  ::posix_spawnattr_setsigdefault(&attr, &all);
  ::posix_spawn_file_actions_addopen(&fa, 0, opts.stdin_path.c_str(), O_RDONLY, 0);
  if (!opts.stdout_path.empty()) {
    ::posix_spawn_file_actions_addopen(&fa, 1, opts.stdout_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
    if (opts.stderr_to_stdout) ::posix_spawn_file_actions_adddup2(&fa, 1, 2);
  }
  if (opts.stderr_fd >= 0) ::posix_spawn_file_actions_adddup2(&fa, opts.stderr_fd, 2);
  ::posix_spawn_file_actions_addclosefrom_np(&fa, 3);
  pid_t pid = 0;
  const int rc = ::posix_spawn(&pid, path.c_str(), &fa, &attr, args.data(), env.data());
  ::posix_spawn_file_actions_destroy(&fa);
  ::posix_spawnattr_destroy(&attr);
  if (rc != 0) return fail(std::strerror(rc));
  return pid;
}

void die_with_parent() {
  const char* v = std::getenv("DCA_PARENT_PID");
  if (v == nullptr) return;
  const long parent = std::strtol(v, nullptr, 10);
  ::unsetenv("DCA_PARENT_PID");
  if (parent <= 1) return;
  ::prctl(PR_SET_PDEATHSIG, SIGTERM);
  if (::getppid() != static_cast<pid_t>(parent)) ::raise(SIGTERM);  // it died before we asked
}

}  // namespace dca
