// dca.Loop and dca.Timer: the process's event loop and its timers, for Lua.
//
//   local core = require "dca.core"
//   local loop = core.loop()                    -- the one loop of this Lua state
//   local t = core.after(0.5, function(timer) ... end)    -- once, after 0.5 s
//   local p = core.every(0.01, function(timer) ... end)   -- every 10 ms (drift-free: absolute deadlines)
//   p:cancel()
//   loop:run()                                  -- until loop:stop() or nothing is left to wait for
//   loop:run_until(function() return done end, 5)   -- true when done, false after 5 s
//   loop:errors()                               -- number of callback errors so far, and the last message
// An armed timer stays alive (it is not garbage collected) until it fires (after) or is cancelled (every).
#include <lua.hpp>

#include <cstdio>

#include "bindings/lua_loop.h"
#include "bindings/lua_support.h"

namespace dca::lua {
namespace {

constexpr const char* kLoopKey = "dca.loop";
constexpr const char* kLoopMeta = "dca.Loop";
constexpr const char* kTimerMeta = "dca.Timer";

struct LoopUD {
  LoopState* ls;
};

// --- invoking Lua callbacks -----------------------------------------------------------------------------------

struct CallCtx {
  const LuaRef* fn;
  const std::function<int(lua_State*)>* push;
};

// Runs inside lua_pcall: pushes the function and its arguments, then calls it.
int trampoline(lua_State* L) {
  auto* c = static_cast<CallCtx*>(lua_touserdata(L, 1));
  lua_settop(L, 0);
  c->fn->push(L);
  const int n = c->push ? (*c->push)(L) : 0;
  lua_call(L, n, 0);
  return 0;
}

// --- Loop -----------------------------------------------------------------------------------------------------

int loop_gc(lua_State* L) {
  auto* ud = static_cast<LoopUD*>(luaL_checkudata(L, 1, kLoopMeta));
  if (ud->ls != nullptr) {
    *ud->ls->alive = false;
    ud->ls->suppress++;
    LoopState* ls = ud->ls;
    ud->ls = nullptr;
    delete ls;  // destroys the io_context and every handler it still holds
  }
  return 0;
}

LoopState& check_loop(lua_State* L) {
  auto* ud = static_cast<LoopUD*>(luaL_checkudata(L, 1, kLoopMeta));
  if (ud->ls == nullptr) luaL_error(L, "dca.Loop: the loop is closed");
  return *ud->ls;
}

int loop_run(lua_State* L) {
  LoopState& ls = check_loop(L);
  lua_State* prev = ls.current;
  ls.current = L;
  char err[256] = {};
  try {
    ls.loop.run();
  } catch (const std::exception& e) {
    std::snprintf(err, sizeof err, "%s", e.what());
  }
  ls.current = prev;
  if (err[0] != '\0') return luaL_error(L, "dca.Loop:run: %s", err);
  return 0;
}

// The predicate of run_until, called under pcall from C++.
struct UntilCtx {
  lua_State* L;
  int fn_index;
  bool failed = false;
};

// Runs under pcall with (ctx, predicate) as arguments.
int call_predicate(lua_State* L) {
  lua_pushvalue(L, 2);
  lua_call(L, 0, 1);
  lua_pushboolean(L, lua_toboolean(L, -1));
  return 1;
}

int loop_run_until(lua_State* L) {
  LoopState& ls = check_loop(L);
  luaL_checktype(L, 2, LUA_TFUNCTION);
  const double timeout = luaL_checknumber(L, 3);
  luaL_argcheck(L, timeout >= 0, 3, "timeout must be >= 0 seconds");
  lua_settop(L, 3);
  UntilCtx ctx{L, 2};
  char err[256] = {};
  int status = LUA_OK;
  bool result = false;
  {
    lua_State* prev = ls.current;
    ls.current = L;
    const auto pred = [&]() -> bool {
      if (ctx.failed) return true;
      lua_pushcfunction(L, message_handler);
      lua_pushcfunction(L, call_predicate);
      lua_pushlightuserdata(L, &ctx);
      lua_pushvalue(L, ctx.fn_index);
      status = lua_pcall(L, 2, 1, -4);
      if (status != LUA_OK) {
        ctx.failed = true;
        lua_remove(L, -2);  // keep the error message on top
        return true;
      }
      const bool r = lua_toboolean(L, -1) != 0;
      lua_pop(L, 2);
      return r;
    };
    try {
      result = ls.loop.run_until(pred, std::chrono::duration_cast<std::chrono::nanoseconds>(
                                           std::chrono::duration<double>(timeout)));
    } catch (const std::exception& e) {
      std::snprintf(err, sizeof err, "%s", e.what());
    }
    ls.current = prev;
  }
  if (err[0] != '\0') return luaL_error(L, "dca.Loop:run_until: %s", err);
  if (ctx.failed) return lua_error(L);  // the predicate's error (with traceback), raised outside C++ scopes
  lua_pushboolean(L, result);
  return 1;
}

int loop_stop(lua_State* L) {
  check_loop(L).loop.stop();
  return 0;
}

int loop_errors(lua_State* L) {
  LoopState& ls = check_loop(L);
  lua_pushinteger(L, static_cast<lua_Integer>(ls.errors));
  if (ls.last_error.empty()) {
    lua_pushnil(L);
  } else {
    lua_pushlstring(L, ls.last_error.data(), ls.last_error.size());
  }
  return 2;
}

int loop_tostring(lua_State* L) {
  auto* ud = static_cast<LoopUD*>(luaL_checkudata(L, 1, kLoopMeta));
  lua_pushstring(L, ud->ls == nullptr ? "dca.Loop(closed)" : "dca.Loop");
  return 1;
}

int core_loop(lua_State* L) {
  loop_state(L);
  lua_getfield(L, LUA_REGISTRYINDEX, kLoopKey);
  return 1;
}

// --- Timer ----------------------------------------------------------------------------------------------------

struct TimerImpl {
  explicit TimerImpl(LoopState& s) : ls(&s), timer(s.loop.io()) {}
  LoopState* ls;
  boost::asio::steady_timer timer;
  std::unique_ptr<LuaRef> fn;
  std::chrono::nanoseconds period{0};  // 0: one-shot
  double seconds = 0;
  bool active = false;
  int self = LUA_NOREF;  // anchor of the userdata while armed
};

struct TimerUD {
  std::shared_ptr<TimerImpl> t;
};

void arm(const std::shared_ptr<TimerImpl>& timer) {
  std::weak_ptr<TimerImpl> w = timer;
  timer->timer.async_wait([w](const boost::system::error_code& ec) {
    auto t = w.lock();
    if (ec || !t || !t->active || !*t->ls->alive) return;
    const bool periodic = t->period.count() > 0;
    if (periodic) {
      t->timer.expires_at(t->timer.expiry() + t->period);
      arm(t);
    } else {
      t->active = false;
    }
    const int self = t->self;
    invoke(*t->fn, [self](lua_State* L) {
      push_anchored(L, self);
      return 1;
    });
    if (!periodic) unanchor(*t->ls, t->self);
  });
}

int make_timer(lua_State* L, bool periodic) {
  const double s = luaL_checknumber(L, 1);
  luaL_argcheck(L, s >= 0 && s < 1e9, 1, "seconds must be >= 0");
  luaL_argcheck(L, !periodic || s > 0, 1, "a periodic timer needs a period > 0");
  luaL_checktype(L, 2, LUA_TFUNCTION);
  LoopState& ls = loop_state(L);
  auto* ud = static_cast<TimerUD*>(lua_newuserdatauv(L, sizeof(TimerUD), 0));
  new (ud) TimerUD{std::make_shared<TimerImpl>(ls)};
  luaL_setmetatable(L, kTimerMeta);
  auto& t = ud->t;
  t->fn = std::make_unique<LuaRef>(L, 2, ls);
  t->seconds = s;
  const auto d = std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::duration<double>(s));
  if (periodic) t->period = d;
  t->active = true;
  t->self = anchor(L, -1);
  t->timer.expires_after(d);
  arm(t);
  return 1;
}

int core_after(lua_State* L) { return make_timer(L, false); }
int core_every(lua_State* L) { return make_timer(L, true); }

TimerUD* check_timer(lua_State* L) { return static_cast<TimerUD*>(luaL_checkudata(L, 1, kTimerMeta)); }

void cancel(TimerUD* ud) {
  if (!ud->t || !ud->t->active) return;
  ud->t->active = false;
  ud->t->timer.cancel();
  if (*ud->t->ls->alive) unanchor(*ud->t->ls, ud->t->self);
}

int timer_cancel(lua_State* L) {
  auto* ud = check_timer(L);
  const bool was = ud->t && ud->t->active;
  cancel(ud);
  lua_pushboolean(L, was);
  return 1;
}

int timer_active(lua_State* L) {
  auto* ud = check_timer(L);
  lua_pushboolean(L, ud->t && ud->t->active);
  return 1;
}

int timer_gc(lua_State* L) {
  auto* ud = check_timer(L);
  if (ud->t) {
    ud->t->active = false;
    if (*ud->t->ls->alive) ud->t->timer.cancel();
  }
  ud->~TimerUD();
  return 0;
}

int timer_tostring(lua_State* L) {
  auto* ud = check_timer(L);
  if (!ud->t) {
    lua_pushstring(L, "dca.Timer(closed)");
  } else {
    lua_pushfstring(L, "dca.Timer(%s %f s, %s)", ud->t->period.count() > 0 ? "every" : "after", ud->t->seconds,
                    ud->t->active ? "armed" : "done");
  }
  return 1;
}

}  // namespace

// --- shared plumbing ------------------------------------------------------------------------------------------

LoopState& loop_state(lua_State* L) {
  lua_getfield(L, LUA_REGISTRYINDEX, kLoopKey);
  if (auto* ud = static_cast<LoopUD*>(luaL_testudata(L, -1, kLoopMeta)); ud != nullptr && ud->ls != nullptr) {
    lua_pop(L, 1);
    return *ud->ls;
  }
  lua_pop(L, 1);
  auto* ud = static_cast<LoopUD*>(lua_newuserdatauv(L, sizeof(LoopUD), 0));
  ud->ls = nullptr;
  luaL_setmetatable(L, kLoopMeta);
  ud->ls = new LoopState();
  lua_rawgeti(L, LUA_REGISTRYINDEX, LUA_RIDX_MAINTHREAD);
  ud->ls->main = lua_tothread(L, -1);
  lua_pop(L, 1);
  lua_setfield(L, LUA_REGISTRYINDEX, kLoopKey);
  lua_getfield(L, LUA_REGISTRYINDEX, kLoopKey);
  auto* again = static_cast<LoopUD*>(lua_touserdata(L, -1));
  lua_pop(L, 1);
  return *again->ls;
}

LuaRef::LuaRef(lua_State* L, int index, LoopState& ls) : ls_(&ls), alive_(ls.alive) {
  lua_pushvalue(L, index);
  ref_ = luaL_ref(L, LUA_REGISTRYINDEX);
}

LuaRef::~LuaRef() {
  if (*alive_) luaL_unref(ls_->main, LUA_REGISTRYINDEX, ref_);
}

void LuaRef::push(lua_State* L) const { lua_rawgeti(L, LUA_REGISTRYINDEX, ref_); }

void invoke(const LuaRef& fn, const std::function<int(lua_State*)>& push_args) {
  LoopState& ls = fn.loop();
  if (ls.suppress > 0 || !*ls.alive) return;
  lua_State* L = ls.current != nullptr ? ls.current : ls.main;
  const int base = lua_gettop(L);
  if (!lua_checkstack(L, 8)) return;
  lua_pushcfunction(L, message_handler);
  lua_pushcfunction(L, trampoline);
  CallCtx ctx{&fn, &push_args};
  lua_pushlightuserdata(L, &ctx);
  if (lua_pcall(L, 1, 0, base + 1) != LUA_OK) {
    const char* msg = lua_tostring(L, -1);
    ls.last_error = msg != nullptr ? msg : "(error object is not a string)";
    ++ls.errors;
    std::fprintf(stderr, "dca: error in a Lua callback: %s\n", ls.last_error.c_str());
    std::fflush(stderr);
  }
  lua_settop(L, base);
}

int anchor(lua_State* L, int index) {
  lua_pushvalue(L, index);
  return luaL_ref(L, LUA_REGISTRYINDEX);
}

void unanchor(LoopState& ls, int& ref) {
  if (ref == LUA_NOREF || ref == LUA_REFNIL) return;
  if (*ls.alive) luaL_unref(ls.main, LUA_REGISTRYINDEX, ref);
  ref = LUA_NOREF;
}

void push_anchored(lua_State* L, int ref) { lua_rawgeti(L, LUA_REGISTRYINDEX, ref); }

void register_loop(lua_State* L) {
  static const luaL_Reg loop_methods[] = {{"run", loop_run},       {"run_until", loop_run_until},
                                          {"stop", loop_stop},     {"errors", loop_errors},
                                          {nullptr, nullptr}};
  register_type(L, kLoopMeta, loop_methods, {loop_gc, nullptr, loop_tostring});
  static const luaL_Reg timer_methods[] = {{"cancel", timer_cancel}, {"active", timer_active}, {nullptr, nullptr}};
  register_type(L, kTimerMeta, timer_methods, {timer_gc, timer_cancel, timer_tostring});
  static const luaL_Reg functions[] = {{"loop", core_loop}, {"after", core_after}, {"every", core_every},
                                       {nullptr, nullptr}};
  luaL_setfuncs(L, functions, 0);
}

}  // namespace dca::lua
