#include "bindings/lua_support.h"

namespace dca::lua {

int message_handler(lua_State* L) {
  const char* msg = lua_tostring(L, 1);
  if (msg == nullptr) {
    if (luaL_callmeta(L, 1, "__tostring") && lua_type(L, -1) == LUA_TSTRING) return 1;
    msg = lua_pushfstring(L, "(error object is a %s value)", luaL_typename(L, 1));
  }
  luaL_traceback(L, L, msg, 1);
  return 1;
}

void register_type(lua_State* L, const char* name, const luaL_Reg* methods, const Metamethods& mm) {
  if (luaL_newmetatable(L, name) != 0) {
    lua_newtable(L);
    luaL_setfuncs(L, methods, 0);
    lua_setfield(L, -2, "__index");
    const struct {
      const char* field;
      lua_CFunction fn;
    } fields[] = {{"__gc", mm.gc}, {"__close", mm.close}, {"__tostring", mm.tostring}};
    for (const auto& f : fields) {
      if (f.fn == nullptr) continue;
      lua_pushcfunction(L, f.fn);
      lua_setfield(L, -2, f.field);
    }
  }
  lua_pop(L, 1);
}

}  // namespace dca::lua
