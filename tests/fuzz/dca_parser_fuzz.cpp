// libFuzzer target for the .dca language front end: dca.lang's parser, checks and model, and the supervisor's
// spec built from the model, all through dca.load.text, the path `dca check` and `dca run` take. Every input
// must either be refused with errors that each name fuzz.dca:LINE:COL (never an "internal parser error", never a
// Lua error escaping), or give a tree whose spec builds and validates without raising. A count hook bounds the
// Lua instructions per input, so an input that makes the front end loop or go exponential is a finding too.
//   build/<b>/bin/fuzz_dca_parser [-runs=N] [-dict=tests/fuzz/dca.dict] [corpus/]
// Lua 5.4 and LPeg are Debian's shared libraries, not instrumented, so libFuzzer's own coverage sees almost nothing:
// a line hook feeds it the Lua side's coverage instead, as edges (previous line -> this line) hashed into
// libFuzzer's extra counters. The Lua code is read from DCA_LUA_DIR.
#include <lua5.4/lua.hpp>

#include <cstdint>
#include <cstdio>
#include <cstdlib>

namespace {

lua_State* L = nullptr;
int check_ref = LUA_NOREF;
long budget = 0;

constexpr long kInstructionBudget = 40'000'000;  // ~100x what the door system's file takes
constexpr int kHookEvery = 1000;

// Lua line-to-line edges, counted where libFuzzer reads extra coverage counters.
constexpr std::size_t kEdges = 1 << 16;
__attribute__((section("__libfuzzer_extra_counters"))) std::uint8_t edge_counters[kEdges];
std::uintptr_t previous_line = 0;

// Runs in Lua: returns nil when the input was handled as the contract says, else the reason it was not.
constexpr const char* kDriver = R"lua(
local load = require "dca.load"
local spec = require "dca.supervisor.spec"
return function(text)
  local ast, tree = load.text(text, "fuzz.dca", { registry = false })
  if not ast then
    if type(tree) ~= "string" then return "the error is a " .. type(tree) .. ", not text" end
    for message in tree:gmatch("fuzz%.dca:%d+:%d+: ([^\n]*)") do
      if message:find("^internal parser error") then return tree end
    end
    if not tree:match("^fuzz%.dca:%d+:%d+: ") then return "an error without fuzz.dca:LINE:COL:\n" .. tree end
    return nil
  end
  if tree then spec.validate(spec.from_model(tree, "fuzz.dca")) end
  return nil
end
)lua";

void hook(lua_State* l, lua_Debug* ar) {
  if (ar->event == LUA_HOOKLINE) {
    if (lua_getinfo(l, "S", ar) == 0) return;
    const std::uintptr_t here = reinterpret_cast<std::uintptr_t>(ar->source) * 31u + static_cast<unsigned>(ar->currentline);
    const std::uintptr_t edge = (here ^ (previous_line >> 1)) * 0x9E3779B97F4A7C15ull;
    previous_line = here;
    std::uint8_t& c = edge_counters[(edge >> 40) % kEdges];
    if (c < 255) ++c;
    return;
  }
  budget -= kHookEvery;
  if (budget < 0) luaL_error(l, "instruction budget of %d exhausted: the front end loops on this input",
                             static_cast<int>(kInstructionBudget));
}

[[noreturn]] void finding(const char* what) {
  std::fprintf(stderr, "fuzz_dca_parser: %s\n", what);
  std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  L = luaL_newstate();
  luaL_openlibs(L);
  lua_getglobal(L, "package");
  lua_pushstring(L, DCA_LUA_DIR "/?.lua;" DCA_LUA_DIR "/?/init.lua");
  lua_setfield(L, -2, "path");
  lua_pop(L, 1);
  if (luaL_dostring(L, kDriver) != LUA_OK) finding(lua_tostring(L, -1));
  check_ref = luaL_ref(L, LUA_REGISTRYINDEX);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  budget = kInstructionBudget;
  previous_line = 0;
  lua_sethook(L, hook, LUA_MASKCOUNT | LUA_MASKLINE, kHookEvery);
  lua_rawgeti(L, LUA_REGISTRYINDEX, check_ref);
  lua_pushlstring(L, reinterpret_cast<const char*>(data), size);
  const int rc = lua_pcall(L, 1, 1, 0);
  lua_sethook(L, nullptr, 0, 0);
  if (rc != LUA_OK) finding(lua_tostring(L, -1));
  if (!lua_isnil(L, -1)) finding(lua_tostring(L, -1));
  lua_pop(L, 1);
  lua_gc(L, LUA_GCCOLLECT);
  return 0;
}
