#pragma once
// The embedded Lua 5.4 interpreter of the `dca` executable.
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

struct lua_State;

namespace dca::lua {

/// One lua_State with the standard libraries, package.path set to the dca Lua modules (dca::lua_dir()),
/// Debian's default package.cpath (so `require "lpeg"` finds lpeg.so) and `dca.core` preloaded.
/// Every chunk runs under lua_pcall with a traceback handler: a Lua error never aborts the process.
class Runtime {
 public:
  Runtime();
  ~Runtime();
  Runtime(const Runtime&) = delete;
  Runtime& operator=(const Runtime&) = delete;

  lua_State* state() const { return L_; }

  /// Runs the Lua file `path` like lua.c: global `arg` (arg[0] = path), the args also as `...`.
  /// Returns the exit code: the chunk's integer result, 0 if it returns none (or true), 1 if it
  /// returns false, and 1 after printing "dca: file:line: message" and the traceback on a Lua error.
  int run_file(const std::string& path, std::span<char* const> args);

  /// Runs `code` named `chunkname`; same exit-code rules as run_file. On error, the message and
  /// traceback go to *error when given, else to stderr.
  int run_string(std::string_view code, const std::string& chunkname, std::string* error = nullptr);

  /// Runs require(module).main(args) for a subcommand written in Lua; same exit-code rules.
  int run_module_main(const std::string& module, std::span<char* const> args);

  /// The `usage` string of Lua subcommand module `module` ("" when it has none or fails to load).
  std::string module_field(const std::string& module, const char* field);

 private:
  int finish(int status, int base, std::string* error);
  lua_State* L_;
};

/// The subcommands written in Lua: the files lua/dca/cli/<name>.lua, as (name, summary) pairs.
std::vector<std::pair<std::string, std::string>> lua_subcommands(Runtime& rt);

}  // namespace dca::lua
