// This process, for the supervisor's tools (`dca run`, `dca supervise`, scenarios):
//
//   core.now()               --> seconds on the monotonic clock (for durations and progress stamps)
//   core.pid()               --> this process's id
//   core.exe_path()          --> the path of the running executable (/proc/self/exe resolved)
//   core.isatty(fd)          --> whether descriptor fd (1 stdout, 2 stderr) is a terminal
//   core.on_signal(fn | nil) -- fn("INT" | "TERM" | "HUP") from the loop when SIGINT, SIGTERM or SIGHUP
//                               arrives (Ctrl-C, kill, the terminal closed);
//                               replaces any earlier handler; nil restores nothing (the handler stays inert)
//   core.on_usr1(fn)         -- fn() from the loop each time SIGUSR1 arrives (dca run: the emergency stop);
//                               replaces any earlier handler
//   core.on_usr2(fn)         -- fn() from the loop each time SIGUSR2 arrives (dca run: the black box's trigger);
//                               replaces any earlier handler
//   core.pending_signal()    --> "INT" | "TERM" | "HUP" | nil: the first stop signal that arrived since
//                               hold_stop_signals() (dca run, scenario and supervise hold them from main on)
//
// Processes and files, never through a shell (every argument reaches the program as it is):
//   core.spawn({path, arg...}, {stdout = FILE, stdin = FILE, session = bool})
//                            --> pid | nil, err. path is absolute; stdin defaults to /dev/null; stdout FILE
//                               (with stderr) is created 0600; session: its own session (setsid). The child
//                               learns its parent's pid and stops when the parent dies (host/spawn.h).
//   core.kill(pid, "TERM" | "KILL" | "INT" | "STOP" | "CONT" | number) --> true | nil, err
//   core.reap(pid)           --> nil while the child runs; {code = N} or {signal = N} once it ended (a child
//                               of this process; reaped, so no zombie is left)
//   core.sleep(seconds)      -- blocks this thread (bounded waits in start-up only)
//   core.list_dir(path)      --> {name...} | nil, err
//   core.remove_tree(path)   --> true | nil, err
//   core.make_dir(path)      --> true | nil, err: a new directory of mode 0700
//   core.write_new_file(path, data) --> true | nil, err: a new file (it must not exist) of mode 0600
//   core.free_tcp_ports(n)   --> {port...}: n free loopback TCP ports (bound to port 0, then released)
//   core.package_version(bytes) --> a controller package file's version: the first 16 hex digits of its SHA-256
//                               (host/package_store.h; a rolling upgrade's plan names it)
#include <lua.hpp>

#include <fcntl.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <climits>
#include <csignal>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <memory>
#include <string>
#include <system_error>
#include <vector>

#include "bindings/lua_loop.h"
#include "bindings/stop_signals.h"
#include "host/exec.h"
#include "host/package_store.h"
#include "host/paths.h"
#include "host/spawn.h"

namespace dca::bindings {
namespace {

int l_now(lua_State* L) {
  timespec ts{};
  ::clock_gettime(CLOCK_MONOTONIC, &ts);
  lua_pushnumber(L, static_cast<lua_Number>(ts.tv_sec) + static_cast<lua_Number>(ts.tv_nsec) * 1e-9);
  return 1;
}

int l_pid(lua_State* L) {
  lua_pushinteger(L, static_cast<lua_Integer>(::getpid()));
  return 1;
}

int l_exe_path(lua_State* L) {
  const std::string s = dca::exe_path();
  if (s.empty()) {
    lua_pushnil(L);
    lua_pushstring(L, "cannot resolve /proc/self/exe");
    return 2;
  }
  lua_pushlstring(L, s.data(), s.size());
  return 1;
}

// isatty(fd): whether the descriptor (1: stdout, 2: stderr) is a terminal (dca.cli.colour)
int l_isatty(lua_State* L) {
  const lua_Integer fd = luaL_checkinteger(L, 1);
  lua_pushboolean(L, fd >= 0 && fd <= INT_MAX && ::isatty(static_cast<int>(fd)) == 1);
  return 1;
}

const char* stop_signal_name(int sig) { return sig == SIGINT ? "INT" : sig == SIGHUP ? "HUP" : "TERM"; }

int l_on_signal(lua_State* L) {
  auto& ls = dca::lua::loop_state(L);
  std::shared_ptr<dca::lua::LuaRef> fn;
  if (!lua_isnoneornil(L, 1)) {
    luaL_checktype(L, 1, LUA_TFUNCTION);
    fn = std::make_shared<dca::lua::LuaRef>(L, 1, ls);
  }
  // a process that stops its tree on these signals must not die by SIGPIPE first (its output piped to a
  // reader that the same hang-up ended): writes then fail with EPIPE instead
  std::signal(SIGPIPE, SIG_IGN);
  ls.loop.on_signals({SIGINT, SIGTERM, SIGHUP}, [fn](int sig) {
    if (!fn) return;
    dca::lua::invoke(*fn, [sig](lua_State* S) {
      lua_pushstring(S, stop_signal_name(sig));
      return 1;
    });
  });
  return 0;
}

// fn (argument 1) from the loop each time `sig` arrives.
int on_extra_signal(lua_State* L, int sig) {
  auto& ls = dca::lua::loop_state(L);
  luaL_checktype(L, 1, LUA_TFUNCTION);
  auto fn = std::make_shared<dca::lua::LuaRef>(L, 1, ls);
  ls.loop.on_signal(sig, [fn] { dca::lua::invoke(*fn, [](lua_State*) { return 0; }); });
  return 0;
}

int l_on_usr1(lua_State* L) { return on_extra_signal(L, SIGUSR1); }
int l_on_usr2(lua_State* L) { return on_extra_signal(L, SIGUSR2); }

volatile std::sig_atomic_t g_pending_signal = 0;

void note_stop_signal(int sig) {
  if (g_pending_signal == 0) g_pending_signal = sig;
}

int l_pending_signal(lua_State* L) {
  if (g_pending_signal == 0) return 0;
  lua_pushstring(L, stop_signal_name(g_pending_signal));
  return 1;
}

int push_error(lua_State* L, const std::string& what) {
  lua_pushnil(L);
  lua_pushlstring(L, what.data(), what.size());
  return 2;
}

int push_errno(lua_State* L, const std::string& what) { return push_error(L, what + ": " + std::strerror(errno)); }

std::string opt_string(lua_State* L, int idx, const char* field, const char* fallback) {
  if (!lua_istable(L, idx)) return fallback;
  lua_getfield(L, idx, field);
  std::string v = lua_isstring(L, -1) ? lua_tostring(L, -1) : fallback;
  lua_pop(L, 1);
  return v;
}

int l_spawn(lua_State* L) {
  luaL_checktype(L, 1, LUA_TTABLE);
  std::vector<std::string> argv;
  const lua_Integer n = luaL_len(L, 1);
  for (lua_Integer i = 1; i <= n; ++i) {
    lua_geti(L, 1, i);
    std::size_t len = 0;
    const char* a = lua_tolstring(L, -1, &len);
    if (a == nullptr) return push_error(L, "spawn: argument " + std::to_string(i) + " is not a string");
    argv.emplace_back(a, len);
    lua_pop(L, 1);
  }
  if (argv.empty() || argv[0].empty() || argv[0][0] != '/') return push_error(L, "spawn: needs an absolute path");
  dca::SpawnOptions o;
  o.stdin_path = opt_string(L, 2, "stdin", "/dev/null");
  o.stdout_path = opt_string(L, 2, "stdout", "");
  if (lua_istable(L, 2)) {
    lua_getfield(L, 2, "session");
    o.new_session = lua_toboolean(L, -1) != 0;
    lua_pop(L, 1);
  }
  std::string error;
  const auto pid = dca::spawn_process(argv[0], argv, o, &error);
  if (!pid) return push_error(L, error);
  lua_pushinteger(L, *pid);
  return 1;
}

// A signal given by number or by name ("TERM", "SIGKILL", ...; host/exec's signal_number).
int signal_arg(lua_State* L, int idx) {
  if (lua_isinteger(L, idx)) return static_cast<int>(lua_tointeger(L, idx));
  const char* name = luaL_optstring(L, idx, "TERM");
  const int sig = dca::signal_number(name);
  return sig != 0 ? sig : luaL_error(L, "unknown signal '%s'", name);
}

int l_kill(lua_State* L) {
  const auto pid = static_cast<pid_t>(luaL_checkinteger(L, 1));
  if (pid <= 0) return push_error(L, "kill: pid must be positive");
  if (::kill(pid, signal_arg(L, 2)) != 0) return push_errno(L, "kill " + std::to_string(pid));
  lua_pushboolean(L, 1);
  return 1;
}

int l_reap(lua_State* L) {
  const auto pid = static_cast<pid_t>(luaL_checkinteger(L, 1));
  int st = 0;
  pid_t r = 0;
  do {
    r = ::waitpid(pid, &st, WNOHANG);
  } while (r < 0 && errno == EINTR);
  if (r <= 0) return 0;
  lua_newtable(L);
  if (WIFSIGNALED(st)) lua_pushinteger(L, WTERMSIG(st)), lua_setfield(L, -2, "signal");
  else lua_pushinteger(L, WEXITSTATUS(st)), lua_setfield(L, -2, "code");
  return 1;
}

int l_sleep(lua_State* L) {
  const double s = luaL_checknumber(L, 1);
  if (s > 0) {
    timespec ts{static_cast<time_t>(s), static_cast<long>((s - static_cast<double>(static_cast<time_t>(s))) * 1e9)};
    while (::nanosleep(&ts, &ts) != 0 && errno == EINTR) {}
  }
  return 0;
}

int l_list_dir(lua_State* L) {
  const char* path = luaL_checkstring(L, 1);
  std::error_code ec;
  std::filesystem::directory_iterator it(path, ec);
  if (ec) return push_error(L, std::string("cannot list ") + path + ": " + ec.message());
  lua_newtable(L);
  lua_Integer i = 0;
  for (; it != std::filesystem::directory_iterator(); it.increment(ec)) {
    if (ec) break;
    lua_pushstring(L, it->path().filename().c_str());
    lua_rawseti(L, -2, ++i);
  }
  return 1;
}

int l_remove_tree(lua_State* L) {
  const char* path = luaL_checkstring(L, 1);
  std::error_code ec;
  std::filesystem::remove_all(path, ec);
  if (ec) return push_error(L, std::string("cannot remove ") + path + ": " + ec.message());
  lua_pushboolean(L, 1);
  return 1;
}

int l_make_dir(lua_State* L) {
  const char* path = luaL_checkstring(L, 1);
  if (::mkdir(path, 0700) != 0) return push_errno(L, std::string("cannot create directory ") + path);
  lua_pushboolean(L, 1);
  return 1;
}

int l_write_new_file(lua_State* L) {
  const char* path = luaL_checkstring(L, 1);
  std::size_t len = 0;
  const char* data = luaL_checklstring(L, 2, &len);
  const int fd = ::open(path, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
  if (fd < 0) return push_errno(L, std::string("cannot create ") + path);
  const bool ok = ::write(fd, data, len) == static_cast<ssize_t>(len);
  const int saved = errno;
  ::close(fd);
  errno = saved;
  if (!ok) return push_errno(L, std::string("cannot write ") + path);
  lua_pushboolean(L, 1);
  return 1;
}

int l_free_tcp_ports(lua_State* L) {
  const lua_Integer n = luaL_checkinteger(L, 1);
  std::vector<int> fds;
  lua_newtable(L);
  for (lua_Integer i = 1; i <= n; ++i) {
    const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t len = sizeof a;
    if (fd < 0 || ::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 ||
        ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len) != 0) {
      if (fd >= 0) ::close(fd);
      break;
    }
    fds.push_back(fd);
    lua_pushinteger(L, ntohs(a.sin_port));
    lua_rawseti(L, -2, i);
  }
  for (int fd : fds) ::close(fd);
  return 1;
}

int l_package_version(lua_State* L) {
  std::size_t n = 0;
  const char* bytes = luaL_checklstring(L, 1, &n);
  lua_pushstring(L, package_version(std::string_view(bytes, n)).c_str());
  return 1;
}
}  // namespace

void hold_stop_signals() {
  struct sigaction sa {};
  sa.sa_handler = note_stop_signal;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = SA_RESTART;
  for (int sig : {SIGINT, SIGTERM, SIGHUP}) ::sigaction(sig, &sa, nullptr);
}

/// Adds the functions above to the table on the stack top.
void open_process(lua_State* L) {
  static const luaL_Reg fns[] = {{"now", l_now},
                                 {"pid", l_pid},
                                 {"exe_path", l_exe_path},
                                 {"isatty", l_isatty},
                                 {"on_signal", l_on_signal},
                                 {"on_usr1", l_on_usr1},
                                 {"on_usr2", l_on_usr2},
                                 {"pending_signal", l_pending_signal},
                                 {"spawn", l_spawn},
                                 {"kill", l_kill},
                                 {"reap", l_reap},
                                 {"sleep", l_sleep},
                                 {"list_dir", l_list_dir},
                                 {"remove_tree", l_remove_tree},
                                 {"make_dir", l_make_dir},
                                 {"write_new_file", l_write_new_file},
                                 {"free_tcp_ports", l_free_tcp_ports},
                                 {"package_version", l_package_version},
                                 {nullptr, nullptr}};
  luaL_setfuncs(L, fns, 0);
}

}  // namespace dca::bindings
