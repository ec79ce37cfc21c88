#include "bindings/core.h"

#include <lua.hpp>

#include "bindings/lua_loop.h"
#include "bindings/wrap_web.h"
#include "host/paths.h"
#include "host/version.h"

namespace dca::bindings {
void open_readline(lua_State* L);  // wrap_readline.cpp
void open_inotify(lua_State* L);   // wrap_inotify.cpp
void open_types(lua_State* L);     // wrap_types.cpp
void open_process(lua_State* L);   // wrap_process.cpp
void open_mcap(lua_State* L);      // wrap_mcap.cpp
void open_taps(lua_State* L);      // wrap_taps.cpp
}  // namespace dca::bindings

extern "C" int luaopen_dca_core(lua_State* L) {
  lua_newtable(L);
  const auto v = dca::version();
  lua_pushlstring(L, v.data(), v.size());
  lua_setfield(L, -2, "version");
  const auto dir = dca::lua_dir();
  lua_pushlstring(L, dir.data(), dir.size());
  lua_setfield(L, -2, "lua_dir");
  const auto worlds = dca::worlds_dir();
  lua_pushlstring(L, worlds.data(), worlds.size());
  lua_setfield(L, -2, "worlds_dir");
  dca::bindings::open_readline(L);
  dca::bindings::open_inotify(L);
  dca::bindings::open_types(L);
  dca::bindings::open_process(L);
  dca::bindings::open_mcap(L);
  dca::bindings::open_taps(L);     // core.tap_point, core.foxglove
  dca::lua::register_loop(L);     // core.loop, core.after, core.every (wrap_loop.cpp)
  dca::lua::register_channel(L);  // core.connect, core.listen (wrap_channel.cpp)
  dca::lua::register_web(L);      // core.web_listen, core.json_encode/decode (wrap_web.cpp)
  return 1;
}
