#include "bindings/lua_value.h"

#include <cmath>
#include <lua.hpp>

namespace dca::lua {
namespace {

std::string key_path(lua_State* L, int key_index, const std::string& parent) {
  if (lua_type(L, key_index) == LUA_TSTRING) return parent + "." + lua_tostring(L, key_index);
  if (lua_isinteger(L, key_index)) return parent + "[" + std::to_string(lua_tointeger(L, key_index)) + "]";
  return parent + "[?]";
}

bool convert(lua_State* L, int index, wire::Value& out, std::string* error, const std::string& path, int depth);

// The length n when the table at `index` is a sequence 1..n, else -1 (its entry count in `count`).
lua_Integer sequence_length(lua_State* L, int index, lua_Integer& count) {
  lua_Integer max_key = 0;
  bool all_positive_ints = true;
  count = 0;
  lua_pushnil(L);
  while (lua_next(L, index) != 0) {
    lua_pop(L, 1);
    ++count;
    if (lua_isinteger(L, -1) && lua_tointeger(L, -1) >= 1) {
      if (lua_tointeger(L, -1) > max_key) max_key = lua_tointeger(L, -1);
    } else {
      all_positive_ints = false;
    }
  }
  return count > 0 && all_positive_ints && max_key == count ? count : -1;
}

// The sequence 1..n at `index` as an array.
bool convert_array(lua_State* L, int index, lua_Integer n, wire::Value& out, std::string* error,
                   const std::string& path, int depth) {
  wire::Value::Array a(static_cast<std::size_t>(n));
  for (lua_Integer i = 1; i <= n; ++i) {
    lua_rawgeti(L, index, i);
    const bool ok = convert(L, -1, a[static_cast<std::size_t>(i - 1)], error, path + "[" + std::to_string(i) + "]",
                            depth + 1);
    lua_pop(L, 1);
    if (!ok) return false;
  }
  out = wire::Value(std::move(a));
  return true;
}

// The table at `index` as a map (keys: strings, numbers or booleans).
bool convert_map(lua_State* L, int index, lua_Integer count, wire::Value& out, std::string* error,
                 const std::string& path, int depth) {
  wire::Value::Map m;
  m.reserve(static_cast<std::size_t>(count));
  lua_pushnil(L);
  while (lua_next(L, index) != 0) {
    wire::Value k, v;
    const int kt = lua_type(L, -2);
    if (kt != LUA_TSTRING && kt != LUA_TNUMBER && kt != LUA_TBOOLEAN) {
      *error = path + ": cannot send a table key of type " + lua_typename(L, kt);
      lua_pop(L, 2);
      return false;
    }
    // Convert the key from a copy: lua_tolstring on a number key would confuse lua_next.
    lua_pushvalue(L, -2);
    convert(L, -1, k, error, path, depth + 1);
    lua_pop(L, 1);
    const std::string p = key_path(L, -2, path);
    if (!convert(L, -1, v, error, p, depth + 1)) {
      lua_pop(L, 2);
      return false;
    }
    m.emplace_back(std::move(k), std::move(v));
    lua_pop(L, 1);
  }
  out = wire::Value(std::move(m));
  return true;
}

// The table at `index`: an array when it is a sequence, else a map; bounded depth (cycles end there).
bool convert_table(lua_State* L, int index, wire::Value& out, std::string* error, const std::string& path, int depth) {
  if (depth >= wire::kMaxDepth) {
    *error = path + ": tables nested deeper than " + std::to_string(wire::kMaxDepth) + " levels (or a cycle)";
    return false;
  }
  if (!lua_checkstack(L, 4)) {
    *error = path + ": Lua stack exhausted";
    return false;
  }
  lua_Integer count = 0;
  const lua_Integer n = sequence_length(L, index, count);
  if (n > 0) return convert_array(L, index, n, out, error, path, depth);
  return convert_map(L, index, count, out, error, path, depth);
}

// The Lua value at `index` as a wire value; false with `error` naming where (`path`) when it cannot be sent.
bool convert(lua_State* L, int index, wire::Value& out, std::string* error, const std::string& path, int depth) {
  index = lua_absindex(L, index);
  switch (lua_type(L, index)) {
    case LUA_TNIL:
      out = wire::Value();
      return true;
    case LUA_TBOOLEAN:
      out = wire::Value(lua_toboolean(L, index) != 0);
      return true;
    case LUA_TNUMBER:
      if (lua_isinteger(L, index)) {
        out = wire::Value(static_cast<std::int64_t>(lua_tointeger(L, index)));
      } else {
        out = wire::Value(static_cast<double>(lua_tonumber(L, index)));
      }
      return true;
    case LUA_TSTRING: {
      std::size_t n = 0;
      const char* s = lua_tolstring(L, index, &n);
      out = wire::Value(std::string(s, n));
      return true;
    }
    case LUA_TTABLE: return convert_table(L, index, out, error, path, depth);
    default:
      *error = path + ": cannot send a " + lua_typename(L, lua_type(L, index));
      return false;
  }
}

}  // namespace

bool to_value(lua_State* L, int index, wire::Value& out, std::string* error) {
  std::string local;
  return convert(L, index, out, error != nullptr ? error : &local, "value", 0);
}

void push_value(lua_State* L, const wire::Value& v) {
  luaL_checkstack(L, 4, "dca: message nested too deeply");
  if (v.is_nil()) {
    lua_pushnil(L);
  } else if (v.is_bool()) {
    lua_pushboolean(L, v.as_bool());
  } else if (v.is_int()) {
    lua_pushinteger(L, static_cast<lua_Integer>(v.as_int()));
  } else if (v.is_float()) {
    lua_pushnumber(L, static_cast<lua_Number>(v.as_float()));
  } else if (v.is_string()) {
    const auto& s = v.as_string();
    lua_pushlstring(L, s.data(), s.size());
  } else if (v.is_array()) {
    const auto& a = v.as_array();
    lua_createtable(L, static_cast<int>(a.size()), 0);
    for (std::size_t i = 0; i < a.size(); ++i) {
      if (a[i].is_nil()) continue;
      push_value(L, a[i]);
      lua_rawseti(L, -2, static_cast<lua_Integer>(i + 1));
    }
  } else {
    const auto& m = v.as_map();
    lua_createtable(L, 0, static_cast<int>(m.size()));
    for (const auto& [k, e] : m) {
      if (k.is_nil() || k.is_array() || k.is_map() || (k.is_float() && std::isnan(k.as_float()))) continue;
      push_value(L, k);
      push_value(L, e);
      lua_rawset(L, -3);
    }
  }
}

bool to_message(lua_State* L, int index, wire::Message& out, std::string* error) {
  std::string local;
  std::string& err = error != nullptr ? *error : local;
  index = lua_absindex(L, index);
  if (lua_type(L, index) != LUA_TTABLE) {
    err = std::string("a message is a table {type = \"...\", ...}, not a ") + lua_typename(L, lua_type(L, index));
    return false;
  }
  lua_getfield(L, index, "type");
  if (lua_type(L, -1) != LUA_TSTRING || lua_rawlen(L, -1) == 0) {
    lua_pop(L, 1);
    err = "a message needs a non-empty string field 'type'";
    return false;
  }
  out.type = lua_tostring(L, -1);
  lua_pop(L, 1);
  out.id = 0;
  lua_getfield(L, index, "id");
  if (!lua_isnil(L, -1)) {
    if (!lua_isinteger(L, -1) || lua_tointeger(L, -1) < 0) {
      lua_pop(L, 1);
      err = "a message's 'id' must be a non-negative integer (it is reserved for the request id)";
      return false;
    }
    out.id = static_cast<std::uint64_t>(lua_tointeger(L, -1));
  }
  lua_pop(L, 1);
  wire::Value payload;
  if (!convert(L, index, payload, &err, "msg", 0)) return false;
  if (payload.is_array()) {
    err = "a message's fields must have names";
    return false;
  }
  drop_envelope_fields(payload);
  out.payload = std::move(payload);
  return true;
}

void drop_envelope_fields(wire::Value& payload) {
  std::erase_if(payload.map_ref(), [](const auto& kv) {
    return kv.first.is_string() && (kv.first.as_string() == "type" || kv.first.as_string() == "id");
  });
}

void push_message(lua_State* L, const wire::Message& m, bool with_id) {
  push_value(L, m.payload.is_map() ? m.payload : wire::Value::map());
  lua_pushlstring(L, m.type.data(), m.type.size());
  lua_setfield(L, -2, "type");
  if (with_id && m.id != 0) {
    lua_pushinteger(L, static_cast<lua_Integer>(m.id));
    lua_setfield(L, -2, "id");
  }
}

}  // namespace dca::lua
