// core.types(): the controller registry's manifests for Lua (dca check uses them).
//   { [TypeName] = { doc = "...", inputs = { {name=, type=, size=, units=, device= (device ports only)} ... }, outputs = {...},
//                    params = { {name=, type=, required=, default=, variadic=, live=, doc=} ... },
//                    ends = "never" | "done" | "aborted" | "done or aborted" | nil (undeclared: anything),
//                    ends_after = the parameter holding the seconds after which it ends (Timer) | nil,
//                    never_when = { param, value } | nil: a run never ends by itself when that parameter is
//                                 that value (a Counter with limit 0),
//                    package = "mylab" (a package's type only) } }
// Controller packages (controllers/packages.h), `system_dir` the .dca file's folder or nil:
//   core.load_package(name, system_dir) --> { name=, file=, version=, types = {...} } | nil, error
//   core.package_dirs(system_dir)       --> { dir, ... }  the search path, in order
//   core.packages(system_dir)           --> { name, ... } the packages found on it, sorted
//   core.absolute(path)                 --> the path made absolute (from the working directory), normalised
// The robot process's signals (bindings/core.h), for dca check's device ports, of world SPEC (default: the default
// world), its options ({"KEY=VALUE", ...}) checked:
//   core.world_signals([SPEC [, OPTIONS]]) --> { world = SPEC (the default's name when none), outputs = { [signal] =
//                                              {name=, type=, size=, units=} }, inputs = {...},
//                                              actuators = { [input] = the input whose actuator it drives } }
//                                | nil, error (a world that cannot be loaded) | nil (no worlds in this executable)
#include <lua.hpp>

#include <filesystem>
#include <string>
#include <system_error>
#include <vector>

#include "bindings/core.h"
#include "controllers/packages.h"
#include <dca/registry.h>
#include "controllers/controller_access.h"
#include "host/paths.h"

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
    if (!p.message.empty()) {
      lua_pushlstring(L, p.message.data(), p.message.size());
      lua_setfield(L, -2, "message");
    }
    lua_rawseti(L, -2, i++);
  }
}

void push_strings(lua_State* L, const std::vector<std::string>& v);

void push_params(lua_State* L, const std::vector<dca::ParamSpec>& params) {
  lua_createtable(L, static_cast<int>(params.size()), 0);
  int i = 1;
  for (const auto& p : params) {
    lua_createtable(L, 0, 7);
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
    lua_pushboolean(L, p.live);
    lua_setfield(L, -2, "live");
    // the range or the allowed values, which dca check holds literal arguments to (dca.lang.check)
    for (const auto& [key, bound] : {std::pair{"min", p.min}, std::pair{"max", p.max}, std::pair{"above", p.above}})
      if (bound) {
        lua_pushnumber(L, *bound);
        lua_setfield(L, -2, key);
      }
    if (const std::string range = dca::range_text(p); !range.empty()) {
      lua_pushlstring(L, range.data(), range.size());
      lua_setfield(L, -2, "range");
    }
    if (!p.allowed.empty()) {
      push_strings(L, p.allowed);
      lua_setfield(L, -2, "allowed");
    }
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
    if (!m->ends.never_when.empty()) {
      lua_createtable(L, 0, 2);
      lua_pushlstring(L, m->ends.never_when.data(), m->ends.never_when.size());
      lua_setfield(L, -2, "param");
      lua_pushlstring(L, m->ends.never_value.data(), m->ends.never_value.size());
      lua_setfield(L, -2, "value");
      lua_setfield(L, -2, "never_when");
    }
    lua_pushlstring(L, m->type.data(), m->type.size());
    lua_setfield(L, -2, "type");
    if (!m->package.empty()) {
      lua_pushlstring(L, m->package.data(), m->package.size());
      lua_setfield(L, -2, "package");
      // a package's type under package.name, and under its name too while no other loaded package has it
      const std::string qualified = m->package + "." + m->type;
      if (dca::Registry::global().manifest(m->type) == m) {
        lua_pushvalue(L, -1);
        lua_setfield(L, -3, m->type.c_str());
      }
      lua_setfield(L, -2, qualified.c_str());
    } else {
      lua_setfield(L, -2, m->type.c_str());
    }
  }
  return 1;
}

void push_strings(lua_State* L, const std::vector<std::string>& v) {
  lua_createtable(L, static_cast<int>(v.size()), 0);
  for (std::size_t i = 0; i < v.size(); ++i) {
    lua_pushlstring(L, v[i].data(), v[i].size());
    lua_rawseti(L, -2, static_cast<lua_Integer>(i + 1));
  }
}

std::string system_dir_arg(lua_State* L, int i) {
  std::size_t n = 0;
  const char* s = lua_isstring(L, i) ? lua_tolstring(L, i, &n) : nullptr;
  return s ? std::string(s, n) : std::string();
}

int l_load_package(lua_State* L) {
  std::size_t n = 0;
  const char* name = luaL_checklstring(L, 1, &n);
  std::string error;
  const auto* p = dca::load_package(std::string(name, n), dca::controller_dirs(system_dir_arg(L, 2)), &error);
  if (!p) {
    lua_pushnil(L);
    lua_pushlstring(L, error.data(), error.size());
    return 2;
  }
  lua_createtable(L, 0, 4);
  lua_pushlstring(L, p->name.data(), p->name.size());
  lua_setfield(L, -2, "name");
  lua_pushlstring(L, p->file.data(), p->file.size());
  lua_setfield(L, -2, "file");
  lua_pushlstring(L, p->version.data(), p->version.size());
  lua_setfield(L, -2, "version");
  push_strings(L, p->types);
  lua_setfield(L, -2, "types");
  return 1;
}

int l_package_dirs(lua_State* L) {
  push_strings(L, dca::controller_dirs(system_dir_arg(L, 1)));
  return 1;
}

int l_packages(lua_State* L) {
  push_strings(L, dca::available_packages(dca::controller_dirs(system_dir_arg(L, 1))));
  return 1;
}

dca::bindings::WorldSignalsSource& world_signals_source() {
  static dca::bindings::WorldSignalsSource source = nullptr;
  return source;
}

void push_signals(lua_State* L, const std::vector<dca::PortSpec>& ports) {
  push_ports(L, ports);
  lua_createtable(L, 0, static_cast<int>(ports.size()));
  for (std::size_t i = 0; i < ports.size(); ++i) {
    lua_rawgeti(L, -2, static_cast<lua_Integer>(i + 1));
    lua_setfield(L, -2, ports[i].name.c_str());
  }
  lua_remove(L, -2);
}

int l_world_signals(lua_State* L) {
  const auto source = world_signals_source();
  if (source == nullptr) {
    lua_pushnil(L);
    return 1;
  }
  std::size_t n = 0;
  const char* spec = luaL_optlstring(L, 1, "", &n);
  std::vector<std::string> options;
  if (lua_istable(L, 2)) {
    for (lua_Integer i = 1; lua_rawgeti(L, 2, i) == LUA_TSTRING; ++i) {
      options.emplace_back(lua_tostring(L, -1));
      lua_pop(L, 1);
    }
    lua_pop(L, 1);
  }
  dca::bindings::WorldSignals s;
  std::string error;
  if (!source(std::string(spec, n), options, &s, &error)) {
    lua_pushnil(L);
    lua_pushlstring(L, error.data(), error.size());
    return 2;
  }
  lua_createtable(L, 0, 3);
  lua_pushlstring(L, s.world.data(), s.world.size());
  lua_setfield(L, -2, "world");
  push_signals(L, s.outputs);
  lua_setfield(L, -2, "outputs");
  push_signals(L, s.inputs);
  lua_setfield(L, -2, "inputs");
  lua_createtable(L, 0, static_cast<int>(s.actuators.size()));
  for (const auto& [input, actuator] : s.actuators) {
    lua_pushlstring(L, actuator.data(), actuator.size());
    lua_setfield(L, -2, input.c_str());
  }
  lua_setfield(L, -2, "actuators");
  return 1;
}

int l_absolute(lua_State* L) {
  std::size_t n = 0;
  const char* path = luaL_checklstring(L, 1, &n);
  std::error_code ec;
  const std::string abs = std::filesystem::absolute(std::string(path, n), ec).lexically_normal().string();
  lua_pushlstring(L, abs.data(), abs.size());
  return 1;
}

}  // namespace

namespace dca::bindings {

void set_world_signals(WorldSignalsSource source) { world_signals_source() = source; }

/// Adds `types` and the package functions to the dca.core table on the top of the stack.
void open_types(lua_State* L) {
  static const luaL_Reg functions[] = {{"types", l_types},   {"load_package", l_load_package},
                                       {"package_dirs", l_package_dirs}, {"packages", l_packages},
                                       {"absolute", l_absolute}, {"world_signals", l_world_signals},
                                       {nullptr, nullptr}};
  luaL_setfuncs(L, functions, 0);
}

}  // namespace dca::bindings
