#include "bindings/lua_runtime.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <lua.hpp>

namespace {

TEST(LuaRuntimeTest, RunsAChunkAndReturnsItsExitCode) {
  dca::lua::Runtime rt;
  EXPECT_EQ(rt.run_string("local x = 6 * 7; return x - 35", "=chunk"), 7);
  EXPECT_EQ(rt.run_string("return", "=chunk"), 0);
  EXPECT_EQ(rt.run_string("return false", "=chunk"), 1);
}

TEST(LuaRuntimeTest, LoadsLpeg) {
  dca::lua::Runtime rt;
  std::string err;
  EXPECT_EQ(rt.run_string("local lpeg = require 'lpeg'\n"
                          "local word = lpeg.C(lpeg.R('az')^1)\n"
                          "assert(lpeg.match(word, 'hello world') == 'hello')",
                          "=lpeg", &err),
            0)
      << err;
}

TEST(LuaRuntimeTest, LoadsDcaCore) {
  dca::lua::Runtime rt;
  std::string err;
  EXPECT_EQ(rt.run_string("local core = require 'dca.core'; assert(type(core.version) == 'string')", "=core", &err), 0)
      << err;
}

TEST(LuaRuntimeTest, ErrorGivesFileLineAndTraceback) {
  dca::lua::Runtime rt;
  std::string err;
  EXPECT_EQ(rt.run_string("local a = 1\nlocal function f() error('boom') end\nf()", "@mychunk.lua", &err), 1);
  EXPECT_NE(err.find("mychunk.lua:2: boom"), std::string::npos) << err;
  EXPECT_NE(err.find("stack traceback"), std::string::npos) << err;
}

TEST(LuaRuntimeTest, SyntaxErrorIsReportedNotThrown) {
  dca::lua::Runtime rt;
  std::string err;
  EXPECT_EQ(rt.run_string("local = 1", "@bad.lua", &err), 1);
  EXPECT_NE(err.find("bad.lua:1:"), std::string::npos) << err;
}

TEST(LuaRuntimeTest, RunFileSetsArgAndPassesVarargs) {
  const auto path = std::filesystem::temp_directory_path() / "dca_runtime_test_args.lua";
  std::ofstream(path) << "local a, b = ...\nassert(arg[1] == a and a == 'x' and b == 'y')\nreturn tonumber(arg[3])\n";
  dca::lua::Runtime rt;
  char x[] = "x", y[] = "y", n[] = "5";
  char* args[] = {x, y, n};
  EXPECT_EQ(rt.run_file(path.string(), args), 5);
  std::filesystem::remove(path);
}

TEST(LuaRuntimeTest, MissingFileIsAnErrorNotACrash) {
  dca::lua::Runtime rt;
  EXPECT_EQ(rt.run_file("/nonexistent/file.lua", {}), 1);
}

TEST(LuaRuntimeTest, StackIsBalancedAfterErrors) {
  dca::lua::Runtime rt;
  const int top = lua_gettop(rt.state());
  std::string err;
  rt.run_string("error('x')", "=e", &err);
  rt.run_string("return 1, 2, 3", "=r", &err);
  EXPECT_EQ(lua_gettop(rt.state()), top);
}

}  // namespace
