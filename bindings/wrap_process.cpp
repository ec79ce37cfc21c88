// This process, for the supervisor's tools (`dca run`, `dca supervise`, scenarios):
//
//   core.now()               --> seconds on the monotonic clock (for durations and progress stamps)
//   core.pid()               --> this process's id
//   core.exe_path()          --> the path of the running executable (/proc/self/exe resolved)
//   core.on_signal(fn | nil) -- fn("INT" | "TERM" | "HUP") from the loop when SIGINT, SIGTERM or SIGHUP
//                               arrives (Ctrl-C, kill, the terminal closed);
//                               replaces any earlier handler; nil restores nothing (the handler stays inert)
#include <lua.hpp>

#include <unistd.h>

#include <csignal>
#include <ctime>
#include <filesystem>
#include <memory>
#include <system_error>

#include "bindings/lua_loop.h"
#include "host/paths.h"

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
      lua_pushstring(S, sig == SIGINT ? "INT" : sig == SIGHUP ? "HUP" : "TERM");
      return 1;
    });
  });
  return 0;
}

}  // namespace

/// Adds now, pid, exe_path and on_signal to the table on the stack top.
void open_process(lua_State* L) {
  static const luaL_Reg fns[] = {{"now", l_now},
                                 {"pid", l_pid},
                                 {"exe_path", l_exe_path},
                                 {"on_signal", l_on_signal},
                                 {nullptr, nullptr}};
  luaL_setfuncs(L, fns, 0);
}

}  // namespace dca::bindings
