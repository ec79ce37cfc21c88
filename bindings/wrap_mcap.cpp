// core.mcap_read: what an MCAP recording holds (host/mcap's bounds-checked reader), for Lua (`dca monitor
// FILE.mcap` replays a recording).
//
//   local rec, err = core.mcap_read("run.mcap")
//   rec.channels[id] = { topic = "/world/door", schema = "/world/door", encoding = "json" }
//   rec.messages[i]  = { channel = id, t = log time in ns (integer), data = "{...}" }   -- in file order
// A file that is not a well-formed MCAP file this reader understands: nil and the reason ("offset N: ...").
#include <lua.hpp>

#include <cstdio>
#include <fstream>
#include <memory>

#include "bindings/lua_support.h"
#include "host/codec/mcap.h"

namespace dca::bindings {
namespace {

// The recording's bytes: at most 1 GiB. False with *error.
bool slurp(const char* path, std::string* out, std::string* error) {
  std::ifstream f(path, std::ios::binary);
  if (!f) {
    *error = "cannot read the recording";
    return false;
  }
  f.seekg(0, std::ios::end);
  const auto size = f.tellg();
  if (size < 0 || size > (std::streamoff{1} << 30)) {
    *error = "not a file of at most 1 GiB";
    return false;
  }
  f.seekg(0);
  out->resize(static_cast<std::size_t>(size));
  f.read(out->data(), size);
  return static_cast<bool>(f);
}

// Pushes the contents as the table described above.
void push_contents(lua_State* L, const mcap::Contents& c) {
  lua_createtable(L, 0, 2);
  lua_createtable(L, 0, static_cast<int>(c.channels.size()));
  for (const auto& [id, ch] : c.channels) {
    lua_createtable(L, 0, 3);
    lua_pushlstring(L, ch.topic.data(), ch.topic.size());
    lua_setfield(L, -2, "topic");
    lua_pushlstring(L, ch.schema_name.data(), ch.schema_name.size());
    lua_setfield(L, -2, "schema");
    lua_pushlstring(L, ch.message_encoding.data(), ch.message_encoding.size());
    lua_setfield(L, -2, "encoding");
    lua_rawseti(L, -2, id);
  }
  lua_setfield(L, -2, "channels");
  lua_createtable(L, static_cast<int>(c.messages.size()), 0);
  lua_Integer i = 1;
  for (const auto& m : c.messages) {
    lua_createtable(L, 0, 3);
    lua_pushinteger(L, m.channel);
    lua_setfield(L, -2, "channel");
    lua_pushinteger(L, static_cast<lua_Integer>(m.log_time));
    lua_setfield(L, -2, "t");
    lua_pushlstring(L, m.data.data(), m.data.size());
    lua_setfield(L, -2, "data");
    lua_rawseti(L, -2, i++);
  }
  lua_setfield(L, -2, "messages");
}

constexpr const char* kContentsMeta = "dca.McapContents";

int contents_gc(lua_State* L) {
  static_cast<mcap::Contents*>(luaL_checkudata(L, 1, kContentsMeta))->~Contents();
  return 0;
}

int l_mcap_read(lua_State* L) {
  const char* path = luaL_checkstring(L, 1);
  // the contents live in a userdata (freed by its __gc), so a Lua error while the tables are built leaks nothing
  auto* contents = static_cast<mcap::Contents*>(lua_newuserdatauv(L, sizeof(mcap::Contents), 0));
  new (contents) mcap::Contents();
  luaL_setmetatable(L, kContentsMeta);
  char err[512] = {};
  try {
    std::string bytes, error;
    if (!slurp(path, &bytes, &error) || !mcap::read(bytes, contents, &error))
      std::snprintf(err, sizeof err, "%s: %s", path, error.c_str());
  } catch (const std::exception& e) {
    std::snprintf(err, sizeof err, "%s: %s", path, e.what());
  }
  if (err[0] != '\0') {
    lua_pushnil(L);
    lua_pushstring(L, err);
    return 2;
  }
  push_contents(L, *contents);
  return 1;
}

}  // namespace

void open_mcap(lua_State* L) {
  static const luaL_Reg none[] = {{nullptr, nullptr}};
  lua::register_type(L, kContentsMeta, none, {contents_gc, nullptr, nullptr});
  static const luaL_Reg functions[] = {{"mcap_read", l_mcap_read}, {nullptr, nullptr}};
  luaL_setfuncs(L, functions, 0);
}

}  // namespace dca::bindings
