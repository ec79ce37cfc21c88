#include "bindings/lua_value.h"

#include <gtest/gtest.h>

#include <lua.hpp>

#include "bindings/lua_runtime.h"

namespace {

using dca::wire::Value;

class LuaValueTest : public ::testing::Test {
 protected:
  // Evaluates `expr` and converts the result.
  bool convert(const std::string& expr, Value& out, std::string* error) {
    lua_State* L = rt_.state();
    const int top = lua_gettop(L);
    EXPECT_EQ(luaL_dostring(L, ("return " + expr).c_str()), LUA_OK) << lua_tostring(L, -1);
    const bool ok = dca::lua::to_value(L, -1, out, error);
    lua_settop(L, top);
    return ok;
  }
  dca::lua::Runtime rt_;
};

TEST_F(LuaValueTest, SequencesBecomeArraysAndOtherTablesMaps) {
  Value v;
  std::string error;
  ASSERT_TRUE(convert("{1, 'two', 3.5, true}", v, &error)) << error;
  EXPECT_EQ(v, Value(Value::Array{1, "two", 3.5, true}));
  ASSERT_TRUE(convert("{}", v, &error));
  EXPECT_TRUE(v.is_map());
  ASSERT_TRUE(convert("{a = 1}", v, &error));
  EXPECT_EQ(v["a"].as_int(), 1);
  ASSERT_TRUE(convert("{[1] = 'x', [3] = 'z'}", v, &error));  // holes: a map with integer keys
  ASSERT_TRUE(v.is_map());
  EXPECT_EQ(v.as_map().size(), 2u);
  ASSERT_TRUE(convert("math.maxinteger", v, &error));
  EXPECT_EQ(v.as_int(), INT64_MAX);
  ASSERT_TRUE(convert("2^53", v, &error));
  EXPECT_TRUE(v.is_float());
}

TEST_F(LuaValueTest, RefusesWhatCannotTravel) {
  Value v;
  std::string error;
  EXPECT_FALSE(convert("{f = print}", v, &error));
  EXPECT_EQ(error, "value.f: cannot send a function");
  EXPECT_FALSE(convert("(function() local t = {}; t.t = t; return t end)()", v, &error));
  EXPECT_NE(error.find("nested deeper than 64"), std::string::npos) << error;
  EXPECT_FALSE(convert("{[{}] = 1}", v, &error));
  EXPECT_NE(error.find("table key of type table"), std::string::npos) << error;
}

TEST_F(LuaValueTest, PushesEveryKindBack) {
  lua_State* L = rt_.state();
  Value::Map weird;
  weird.emplace_back(Value(1), Value("a"));
  weird.emplace_back(Value(0.0 / 0.0), Value("nan key dropped"));
  weird.emplace_back(Value("k"), Value(Value::Array{Value(), 2}));
  dca::lua::push_value(L, Value(weird));
  lua_setglobal(L, "w");
  std::string err;
  EXPECT_EQ(rt_.run_string("assert(w[1] == 'a'); assert(w.k[1] == nil and w.k[2] == 2)\n"
                           "local n = 0; for _ in pairs(w) do n = n + 1 end; assert(n == 2, n)",
                           "=check", &err),
            0)
      << err;
}

TEST_F(LuaValueTest, MessagesAreTablesWithAType) {
  lua_State* L = rt_.state();
  dca::lua::push_message(L, dca::wire::Message{"spawn", 3, Value::map().set("argv", Value::Array{"dca"})});
  lua_setglobal(L, "m");
  std::string err;
  EXPECT_EQ(rt_.run_string("assert(m.type == 'spawn' and m.argv[1] == 'dca')", "=check", &err), 0) << err;
  ASSERT_EQ(luaL_dostring(L, "return {type = 'lookup', name = 'x'}"), LUA_OK);
  dca::wire::Message out;
  ASSERT_TRUE(dca::lua::to_message(L, -1, out, &err)) << err;
  lua_pop(L, 1);
  EXPECT_EQ(out.type, "lookup");
  EXPECT_EQ(out.payload.str(), "{name = \"x\"}");
}

// Closing the Lua state with open channels, a listener and armed timers neither crashes nor calls Lua.
TEST_F(LuaValueTest, ClosingTheStateWithOpenChannelsIsSafe) {
  std::string err;
  EXPECT_EQ(rt_.run_string(R"(
    local core = require "dca.core"
    local key = "0123456789abcdef0123456789abcdef"
    local loop = core.loop()
    local got
    local l = core.listen("127.0.0.1:0", {key = key}, function(ch)
      ch:on_close(function() error("must not run while the state closes") end)
    end)
    core.connect(l:address(), {key = key}, function(ch) got = ch end)
    core.every(0.001, function() end)
    core.after(100, function() end)
    assert(loop:run_until(function() return got end, 10))
    got:request({type = "never"}, 100, function() error("must not run either") end)
  )", "=open", &err), 0) << err;
  // rt_ is destroyed by the fixture: ASan/UBSan watch this in CI.
}

}  // namespace
