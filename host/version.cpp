#include "host/version.h"

#include <cstdlib>
#include <filesystem>
#include <system_error>

#include "dca/version.h"

namespace dca {

std::string_view version() { return DCA_VERSION_STRING; }

std::string lua_dir() {
  namespace fs = std::filesystem;
  if (const char* env = std::getenv("DCA_LUA_DIR"); env != nullptr && *env != '\0') return env;
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const fs::path installed = exe.parent_path().parent_path() / DCA_INSTALL_LUA_DIR;
    if (fs::is_directory(installed / "dca", ec)) return installed.string();
  }
  return DCA_SOURCE_LUA_DIR;
}

}  // namespace dca
