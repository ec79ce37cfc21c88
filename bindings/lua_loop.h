#pragma once
// The process's event loop as seen from Lua, and the plumbing every binding with callbacks uses:
// references to Lua functions held by C++ objects, and calling them from the loop safely.
//
// Rules (STYLE.md, Bindings): a Lua callback always runs under lua_pcall with a traceback handler; an error in
// it is printed on stderr ("dca: error in a Lua callback: <message>" and the traceback), counted
// (core.loop():errors()), and the loop goes on. No C++ exception crosses into Lua; no Lua error unwinds C++
// frames (arguments are pushed inside the protected call).
#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "host/loop.h"

struct lua_State;

namespace dca::lua {

/// The loop of one Lua state (created on first use, destroyed with the state).
struct LoopState {
  dca::Loop loop;
  lua_State* main = nullptr;     ///< the state's main thread
  lua_State* current = nullptr;  ///< the thread running the loop now (callbacks run on it), else main
  int suppress = 0;              ///< > 0 while the state is closing: callbacks are not called
  std::shared_ptr<bool> alive = std::make_shared<bool>(true);  ///< false once the state is closing
  std::uint64_t errors = 0;      ///< errors raised by callbacks so far
  std::string last_error;        ///< the last one, with its traceback
};

/// The loop of the Lua state `L` (the one `core.loop()` returns), created on first use.
LoopState& loop_state(lua_State* L);

/// A Lua value kept in the registry for C++ (usually a callback); released when destroyed, unless the state
/// is already closing.
class LuaRef {
 public:
  /// References the value at `index` of L's stack.
  LuaRef(lua_State* L, int index, LoopState& ls);
  ~LuaRef();
  LuaRef(const LuaRef&) = delete;
  LuaRef& operator=(const LuaRef&) = delete;
  /// Pushes the value.
  void push(lua_State* L) const;
  LoopState& loop() const { return *ls_; }

 private:
  LoopState* ls_;
  std::shared_ptr<bool> alive_;
  int ref_;
};

/// Calls the function `fn` from the loop with the arguments `push_args(L)` pushes (it returns how many), under
/// lua_pcall with a traceback handler. An error is reported (see above) and swallowed.
void invoke(const LuaRef& fn, const std::function<int(lua_State*)>& push_args);

/// Keeps the userdata at `index` alive until unanchor() (an open channel, an armed timer): returns the anchor.
int anchor(lua_State* L, int index);
/// Releases an anchor made by anchor() (no effect on LUA_NOREF).
void unanchor(LoopState& ls, int& ref);
/// Pushes the anchored userdata.
void push_anchored(lua_State* L, int ref);

/// Registers core.loop, core.after and core.every in the table on top of the stack (wrap_loop.cpp).
void register_loop(lua_State* L);
/// Registers core.connect and core.listen in the table on top of the stack (wrap_channel.cpp).
void register_channel(lua_State* L);

}  // namespace dca::lua
