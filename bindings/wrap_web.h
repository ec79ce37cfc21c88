#pragma once
// dca.WebServer (host/web) for Lua, and the way another binding reaches the C++ server behind a Lua one (e.g. to
// register a C++ Protocol such as Foxglove's on the server `dca run --monitor` started).
#include <memory>

#include "host/web/web.h"

struct lua_State;

namespace dca::lua {

/// The server of the dca.WebServer at `index` (raises a Lua error when it is not one, or it is closed).
std::shared_ptr<web::Server> check_web_server(lua_State* L, int index);
/// Registers core.web_listen, core.json_encode and core.json_decode in the table on top of the stack.
void register_web(lua_State* L);

}  // namespace dca::lua
