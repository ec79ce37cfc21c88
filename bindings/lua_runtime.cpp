#include "bindings/lua_runtime.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <lua.hpp>
#include <stdexcept>

#include "bindings/core.h"
#include "bindings/lua_support.h"
#include "host/paths.h"

namespace dca::lua {
namespace {

void push_args(lua_State* L, std::span<char* const> args) {
  for (char* a : args) lua_pushstring(L, a);
}

}  // namespace

Runtime::Runtime() : L_(luaL_newstate()) {
  if (L_ == nullptr) throw std::runtime_error("cannot create a Lua state (out of memory)");
  luaL_openlibs(L_);
  // package.path: the dca modules first, then Lua's defaults. package.cpath keeps Debian's default.
  const std::string dir = dca::lua_dir();
  lua_getglobal(L_, "package");
  lua_getfield(L_, -1, "path");
  const std::string path = dir + "/?.lua;" + dir + "/?/init.lua;" + lua_tostring(L_, -1);
  lua_pop(L_, 1);
  lua_pushlstring(L_, path.data(), path.size());
  lua_setfield(L_, -2, "path");
  lua_getfield(L_, -1, "preload");
  lua_pushcfunction(L_, luaopen_dca_core);
  lua_setfield(L_, -2, "dca.core");
  lua_pop(L_, 2);
}

Runtime::~Runtime() { lua_close(L_); }

int Runtime::finish(int status, int base, std::string* error) {
  int code = 0;
  if (status != LUA_OK) {
    const char* msg = lua_tostring(L_, -1);
    std::string text = std::string("dca: ") + (msg != nullptr ? msg : "(no error message)");
    if (error != nullptr) {
      *error = text;
    } else {
      std::fprintf(stderr, "%s\n", text.c_str());
      std::fflush(stderr);
    }
    code = 1;
  } else if (lua_gettop(L_) > base) {
    const int first = base + 1;
    if (lua_isinteger(L_, first)) {
      code = static_cast<int>(lua_tointeger(L_, first));
    } else if (lua_isboolean(L_, first)) {
      code = lua_toboolean(L_, first) ? 0 : 1;
    }
  }
  lua_settop(L_, base);
  return code;
}

int Runtime::run_file(const std::string& path, std::span<char* const> args) {
  const int base = lua_gettop(L_);
  // global arg, as lua.c does
  lua_createtable(L_, static_cast<int>(args.size()), 1);
  lua_pushlstring(L_, path.data(), path.size());
  lua_rawseti(L_, -2, 0);
  for (size_t i = 0; i < args.size(); ++i) {
    lua_pushstring(L_, args[i]);
    lua_rawseti(L_, -2, static_cast<lua_Integer>(i + 1));
  }
  lua_setglobal(L_, "arg");

  lua_pushcfunction(L_, message_handler);
  int status = luaL_loadfile(L_, path.c_str());
  if (status == LUA_OK) {
    push_args(L_, args);
    status = lua_pcall(L_, static_cast<int>(args.size()), LUA_MULTRET, base + 1);
  }
  lua_remove(L_, base + 1);  // the handler
  return finish(status, base, nullptr);
}

int Runtime::run_string(std::string_view code, const std::string& chunkname, std::string* error) {
  const int base = lua_gettop(L_);
  lua_pushcfunction(L_, message_handler);
  int status = luaL_loadbuffer(L_, code.data(), code.size(), chunkname.c_str());
  if (status == LUA_OK) status = lua_pcall(L_, 0, LUA_MULTRET, base + 1);
  lua_remove(L_, base + 1);
  return finish(status, base, error);
}

int Runtime::run_module_main(const std::string& module, std::span<char* const> args) {
  const int base = lua_gettop(L_);
  lua_pushcfunction(L_, message_handler);
  // chunk: local m = require(module); return m.main({...})
  int status = luaL_loadstring(L_,
                               "local name = ...\n"
                               "local m = require(name)\n"
                               "if type(m) ~= 'table' or type(m.main) ~= 'function' then\n"
                               "  error(name .. ' has no main function', 0)\n"
                               "end\n"
                               "return m.main(table.pack(select(2, ...)))");
  if (status == LUA_OK) {
    lua_pushlstring(L_, module.data(), module.size());
    push_args(L_, args);
    status = lua_pcall(L_, static_cast<int>(args.size()) + 1, LUA_MULTRET, base + 1);
  }
  lua_remove(L_, base + 1);
  return finish(status, base, nullptr);
}

std::string Runtime::module_field(const std::string& module, const char* field) {
  const int base = lua_gettop(L_);
  lua_getglobal(L_, "require");
  lua_pushlstring(L_, module.data(), module.size());
  std::string out;
  if (lua_pcall(L_, 1, 1, 0) == LUA_OK && lua_istable(L_, -1)) {
    lua_getfield(L_, -1, field);
    if (lua_type(L_, -1) == LUA_TSTRING) out = lua_tostring(L_, -1);
  }
  lua_settop(L_, base);
  return out;
}

std::vector<std::pair<std::string, std::string>> lua_subcommands(Runtime& rt) {
  namespace fs = std::filesystem;
  std::vector<std::pair<std::string, std::string>> out;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(fs::path(dca::lua_dir()) / "dca" / "cli", ec)) {
    if (e.path().extension() != ".lua") continue;
    const std::string name = e.path().stem().string();
    // a module without a summary is a helper of the others (dca.cli.args), not a command
    if (auto summary = rt.module_field("dca.cli." + name, "summary"); !summary.empty())
      out.emplace_back(name, std::move(summary));
  }
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace dca::lua
