#pragma once
// Where a dca process finds its files: the one lookup of the executable's, the Lua modules', the URDF models',
// the runtime (sockets), the state and the configuration directories. Each honours its environment variable
// first; an installed dca (<prefix>/bin/dca) finds <prefix>/share/dca/...; a build tree finds the source tree.
// C++17-clean (sim/ uses it). No function here throws.
#include <string>
#include <vector>

#include <dca/paths.h>

namespace dca {

/// The running executable's path (/proc/self/exe resolved), "" when it cannot be resolved.
std::string exe_path();

/// The directory of the running executable, "" when it cannot be resolved.
std::string exe_dir();

/// The directory that holds the `dca/` Lua modules: $DCA_LUA_DIR if set; else <exe>/../share/dca/lua when it
/// holds dca/ (an installed dca); else the source tree's lua/ (a build tree).
std::string lua_dir();

// models_dir(): dca/paths.h (the SDK's).

/// The directory of the world plug-ins' own files (docs/worlds.md: worlds/NAME/world.lua, models, systems):
/// $DCA_WORLDS_DIR if set; else <exe>/../share/dca/worlds when it exists (an installed dca); else the source
/// tree's worlds/ (a build tree).
std::string worlds_dir();

/// The directories searched for controller packages (`use NAME;` in a .dca file), in order: each entry of
/// $DCA_CONTROLLER_PATH (':'-separated; a relative one taken from the working directory), then
/// <exe>/../lib/dca/controllers (where an installed dca, and a build tree, keep theirs), then
/// <system_dir>/packages when `system_dir` (the .dca file's directory) is not "". The same rule on every host.
std::vector<std::string> controller_dirs(const std::string& system_dir = "");

/// Where a process puts its Unix sockets: $XDG_RUNTIME_DIR when writable, else <tmp>/dca-<uid> (created, 0700).
std::string runtime_dir();

/// A daemon's default state directory for `host`: $XDG_STATE_HOME/dca/<host> when $XDG_STATE_HOME is absolute,
/// else $HOME/.local/state/dca/<host>; "" when neither is set.
std::string state_dir(const std::string& host);

/// The user's dca configuration directory (the key file's): $XDG_CONFIG_HOME/dca, else $HOME/.config/dca
/// (./.config/dca without $HOME).
std::string config_dir();

}  // namespace dca
