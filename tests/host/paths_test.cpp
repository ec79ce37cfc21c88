#include "host/paths.h"

#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <string>

namespace {

namespace fs = std::filesystem;

// Sets environment variable `name` to `value` (nullptr: unsets it) for the scope, then restores it.
class ScopedEnv {
 public:
  ScopedEnv(const char* name, const char* value) : name_(name) {
    if (const char* old = std::getenv(name)) old_ = old, had_ = true;
    if (value != nullptr) ::setenv(name, value, 1); else ::unsetenv(name);
  }
  ~ScopedEnv() {
    if (had_) ::setenv(name_.c_str(), old_.c_str(), 1); else ::unsetenv(name_.c_str());
  }
  ScopedEnv(const ScopedEnv&) = delete;
  ScopedEnv& operator=(const ScopedEnv&) = delete;

 private:
  std::string name_, old_;
  bool had_ = false;
};

TEST(PathsTest, ExePathIsThisTestAndExeDirItsFolder) {
  const fs::path exe = dca::exe_path();
  EXPECT_EQ(exe.filename(), "host_paths_test");
  EXPECT_EQ(dca::exe_dir(), exe.parent_path().string());
}

TEST(PathsTest, LuaDirHonoursEnvironment) {
  ScopedEnv e("DCA_LUA_DIR", "/some/where");
  EXPECT_EQ(dca::lua_dir(), "/some/where");
}

TEST(PathsTest, LuaDirOfABuildTreeIsTheSourceTree) {
  ScopedEnv e("DCA_LUA_DIR", nullptr);
  EXPECT_TRUE(fs::exists(fs::path(dca::lua_dir()) / "dca" / "testing.lua")) << dca::lua_dir();
}

TEST(PathsTest, ModelsDirHonoursEnvironment) {
  ScopedEnv e("DCA_MODELS_DIR", "/models/here");
  EXPECT_EQ(dca::models_dir(), "/models/here");
}

TEST(PathsTest, ModelsDirOfABuildTreeIsTheSourceTree) {
  ScopedEnv e("DCA_MODELS_DIR", nullptr);
  EXPECT_TRUE(fs::exists(fs::path(dca::models_dir()) / "mobile_manipulator.urdf")) << dca::models_dir();
}

TEST(PathsTest, StateDirIsUnderAnAbsoluteXdgStateHomeElseHome) {
  ScopedEnv home("HOME", "/home/u");
  {
    ScopedEnv xdg("XDG_STATE_HOME", "/xdg/state");
    EXPECT_EQ(dca::state_dir("h1"), "/xdg/state/dca/h1");
  }
  {
    ScopedEnv xdg("XDG_STATE_HOME", "relative");
    EXPECT_EQ(dca::state_dir("h1"), "/home/u/.local/state/dca/h1");
  }
  ScopedEnv xdg("XDG_STATE_HOME", nullptr);
  ScopedEnv no_home("HOME", nullptr);
  EXPECT_EQ(dca::state_dir("h1"), "");
}

TEST(PathsTest, ConfigDirIsUnderXdgConfigHomeElseHome) {
  ScopedEnv home("HOME", "/home/u");
  {
    ScopedEnv xdg("XDG_CONFIG_HOME", "/xdg");
    EXPECT_EQ(dca::config_dir(), "/xdg/dca");
  }
  ScopedEnv xdg("XDG_CONFIG_HOME", nullptr);
  EXPECT_EQ(dca::config_dir(), "/home/u/.config/dca");
}

TEST(PathsTest, RuntimeDirIsXdgRuntimeDirWhenWritableElseAPrivateTempDir) {
  const fs::path tmp = fs::temp_directory_path();
  {
    ScopedEnv xdg("XDG_RUNTIME_DIR", tmp.c_str());
    EXPECT_EQ(dca::runtime_dir(), tmp.string());
  }
  ScopedEnv xdg("XDG_RUNTIME_DIR", nullptr);
  const bool existed = fs::exists(tmp / ("dca-" + std::to_string(::getuid())));
  const fs::path d = dca::runtime_dir();
  EXPECT_EQ(d, tmp / ("dca-" + std::to_string(::getuid())));
  EXPECT_EQ(fs::status(d).permissions() & fs::perms::all, fs::perms::owner_all);
  std::error_code ec;
  if (!existed) fs::remove(d, ec);  // the temporary directory is left as it was
}

}  // namespace
