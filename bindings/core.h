#pragma once
// The Lua module `dca.core`: the supervisor's whole view of the C++ core.
struct lua_State;

extern "C" {
/// Opens `dca.core` (registered in package.preload by dca::lua::Runtime).
int luaopen_dca_core(lua_State* L);
}
