#pragma once
// What every binding shares: the one message handler of every lua_pcall, and the one way a bound type
// registers its metatable. The wrap_<type>.cpp files only bind.
#include <lua.hpp>

namespace dca::lua {

/// The message handler of every lua_pcall: the error message (or the error object's __tostring, or a note of
/// its type) followed by a traceback.
int message_handler(lua_State* L);

/// The metamethods of a bound type besides __index (nullptr: none).
struct Metamethods {
  lua_CFunction gc = nullptr;        ///< __gc
  lua_CFunction close = nullptr;     ///< __close (to-be-closed variables)
  lua_CFunction tostring = nullptr;  ///< __tostring
};

/// Registers the metatable `name` (once per state): `methods` (nullptr-terminated) as its __index, and `mm`.
/// Leaves the stack as it was.
void register_type(lua_State* L, const char* name, const luaL_Reg* methods, const Metamethods& mm);

}  // namespace dca::lua
