#pragma once
#include <string>
#include <string_view>

namespace dca {

/// The dca release, as in `dca --version` ("0.1.0").
std::string_view version();

/// The directory that holds the `dca/` Lua modules for this executable: $DCA_LUA_DIR if set; else
/// <exe>/../share/dca/lua when that exists (an installed dca); else the source tree's lua/ (a build tree).
std::string lua_dir();

}  // namespace dca
