#include "host/version.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>

namespace {

TEST(VersionTest, IsTheProjectVersion) {
  const std::string v(dca::version());
  EXPECT_FALSE(v.empty());
  EXPECT_EQ(std::count(v.begin(), v.end(), '.'), 2) << v;
}

TEST(VersionTest, LuaDirHonoursEnvironment) {
  ::setenv("DCA_LUA_DIR", "/some/where", 1);
  EXPECT_EQ(dca::lua_dir(), "/some/where");
  ::unsetenv("DCA_LUA_DIR");
}

TEST(VersionTest, LuaDirOfABuildTreeIsTheSourceTree) {
  ::unsetenv("DCA_LUA_DIR");
  EXPECT_TRUE(std::filesystem::exists(std::filesystem::path(dca::lua_dir()) / "dca" / "testing.lua")) << dca::lua_dir();
}

}  // namespace
