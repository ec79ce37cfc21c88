#include "host/paths.h"

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <system_error>

#include "dca/paths_config.h"

namespace dca {

namespace fs = std::filesystem;

namespace {

// The value of environment variable `name`, nullptr when unset or empty.
const char* env(const char* name) {
  const char* v = std::getenv(name);
  return v != nullptr && *v != '\0' ? v : nullptr;
}

// <exe>/../<relative> when `is_there` holds for it (an installed dca), else `source` (a build tree).
std::string installed_or_source(const char* relative, const char* source, bool (*is_there)(const fs::path&)) {
  const std::string dir = exe_dir();
  if (!dir.empty()) {
    const fs::path installed = fs::path(dir).parent_path() / relative;
    if (is_there(installed)) return installed.string();
  }
  return source;
}

bool is_dir(const fs::path& p) {
  std::error_code ec;
  return fs::is_directory(p, ec);
}

}  // namespace

std::string exe_path() {
  std::error_code ec;
  const fs::path p = fs::read_symlink("/proc/self/exe", ec);
  return ec ? std::string() : p.string();
}

std::string exe_dir() {
  const std::string exe = exe_path();
  return exe.empty() ? exe : fs::path(exe).parent_path().string();
}

std::string lua_dir() {
  if (const char* e = env("DCA_LUA_DIR")) return e;
  return installed_or_source(DCA_INSTALL_LUA_DIR, DCA_SOURCE_LUA_DIR, [](const fs::path& p) {
    std::error_code ec;
    return fs::is_directory(p / "dca", ec);
  });
}

std::string models_dir() {
  if (const char* e = env("DCA_MODELS_DIR")) return e;
  return installed_or_source(DCA_INSTALL_MODELS_DIR, DCA_SOURCE_MODELS_DIR, is_dir);
}

std::string worlds_dir() {
  if (const char* e = env("DCA_WORLDS_DIR")) return e;
  return installed_or_source(DCA_INSTALL_WORLDS_DIR, DCA_SOURCE_WORLDS_DIR, is_dir);
}

std::vector<std::string> controller_dirs(const std::string& system_dir) {
  std::vector<std::string> dirs;
  std::error_code ec;
  if (const char* e = env("DCA_CONTROLLER_PATH")) {
    const std::string path = e;
    for (std::size_t at = 0; at <= path.size();) {
      std::size_t end = path.find(':', at);
      if (end == std::string::npos) end = path.size();
      if (end > at) dirs.push_back(fs::absolute(path.substr(at, end - at), ec).lexically_normal().string());
      at = end + 1;
    }
  }
  if (const std::string dir = exe_dir(); !dir.empty())
    dirs.push_back((fs::path(dir).parent_path() / "lib" / "dca" / "controllers").string());
  if (!system_dir.empty()) dirs.push_back((fs::absolute(system_dir, ec) / "packages").lexically_normal().string());
  return dirs;
}

std::string runtime_dir() {
  if (const char* x = env("XDG_RUNTIME_DIR"); x != nullptr && ::access(x, W_OK) == 0) return x;
  std::error_code ec;
  const fs::path d = fs::temp_directory_path(ec) / ("dca-" + std::to_string(::getuid()));
  fs::create_directories(d, ec);
  fs::permissions(d, fs::perms::owner_all, ec);
  return d.string();
}

std::string state_dir(const std::string& host) {
  if (const char* x = env("XDG_STATE_HOME"); x != nullptr && x[0] == '/') return std::string(x) + "/dca/" + host;
  if (const char* home = env("HOME")) return std::string(home) + "/.local/state/dca/" + host;
  return "";
}

std::string config_dir() {
  if (const char* x = env("XDG_CONFIG_HOME")) return std::string(x) + "/dca";
  const char* home = std::getenv("HOME");
  return std::string(home != nullptr ? home : ".") + "/.config/dca";
}

}  // namespace dca
