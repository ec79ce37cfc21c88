// core.types(): the controller registry's manifests for Lua (dca check uses them).
//   { [TypeName] = { doc = "...", inputs = { {name=, type=, size=, units=, device= (device ports only)} ... }, outputs = {...},
//                    params = { {name=, type=, required=, default=, variadic=, doc=} ... },
//                    ends = "never" | "done" | "aborted" | "done or aborted" | nil (undeclared: anything),
//                    ends_after = the parameter holding the seconds after which it ends (Timer) | nil } }
#include <lua.hpp>

#include "controllers/registry.h"

namespace {

void push_ports(lua_State* L, const std::vector<dca::PortSpec>& ports) {
  lua_createtable(L, static_cast<int>(ports.size()), 0);
  int i = 1;
  for (const auto& p : ports) {
    lua_createtable(L, 0, 4);
    lua_pushlstring(L, p.name.data(), p.name.size());
    lua_setfield(L, -2, "name");
    const auto t = dca::to_string(p.type);
    lua_pushlstring(L, t.data(), t.size());
    lua_setfield(L, -2, "type");
    lua_pushinteger(L, static_cast<lua_Integer>(p.size));
    lua_setfield(L, -2, "size");
    lua_pushlstring(L, p.units.data(), p.units.size());
    lua_setfield(L, -2, "units");
    if (!p.device.empty()) {
      lua_pushlstring(L, p.device.data(), p.device.size());
      lua_setfield(L, -2, "device");
    }
    lua_rawseti(L, -2, i++);
  }
}

void push_params(lua_State* L, const std::vector<dca::ParamSpec>& params) {
  lua_createtable(L, static_cast<int>(params.size()), 0);
  int i = 1;
  for (const auto& p : params) {
    lua_createtable(L, 0, 6);
    lua_pushlstring(L, p.name.data(), p.name.size());
    lua_setfield(L, -2, "name");
    lua_pushlstring(L, p.type.data(), p.type.size());
    lua_setfield(L, -2, "type");
    lua_pushboolean(L, p.required);
    lua_setfield(L, -2, "required");
    if (!p.required && !p.variadic) {
      lua_pushlstring(L, p.default_value.data(), p.default_value.size());
      lua_setfield(L, -2, "default");
    }
    lua_pushboolean(L, p.variadic);
    lua_setfield(L, -2, "variadic");
    lua_pushlstring(L, p.doc.data(), p.doc.size());
    lua_setfield(L, -2, "doc");
    lua_rawseti(L, -2, i++);
  }
}

int l_types(lua_State* L) {
  const auto all = dca::Registry::global().all();
  lua_createtable(L, 0, static_cast<int>(all.size()));
  for (const auto* m : all) {
    lua_createtable(L, 0, 4);
    lua_pushlstring(L, m->doc.data(), m->doc.size());
    lua_setfield(L, -2, "doc");
    push_ports(L, m->inputs);
    lua_setfield(L, -2, "inputs");
    push_ports(L, m->outputs);
    lua_setfield(L, -2, "outputs");
    push_params(L, m->params);
    lua_setfield(L, -2, "params");
    if (const auto e = dca::to_string(m->ends.kind); !e.empty()) {
      lua_pushlstring(L, e.data(), e.size());
      lua_setfield(L, -2, "ends");
    }
    if (!m->ends.after.empty()) {
      lua_pushlstring(L, m->ends.after.data(), m->ends.after.size());
      lua_setfield(L, -2, "ends_after");
    }
    lua_setfield(L, -2, m->type.c_str());
  }
  return 1;
}

}  // namespace

namespace dca::bindings {

/// Adds `types` to the dca.core table on the top of the stack.
void open_types(lua_State* L) {
  lua_pushcfunction(L, l_types);
  lua_setfield(L, -2, "types");
}

}  // namespace dca::bindings
