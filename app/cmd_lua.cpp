// `dca lua FILE [args]`: runs a Lua file with the dca modules on the path (what the Lua tests use).
#include <cstdio>

#include "bindings/lua_runtime.h"
#include "app/subcommand.h"

namespace dca::cli::cmd_lua {
namespace {

int cmd_lua(std::span<char* const> args) {
  if (args.empty()) {
    std::fprintf(stderr, "usage: dca lua FILE [args...]\n");
    return 2;
  }
  dca::lua::Runtime rt;
  return rt.run_file(args[0], args.subspan(1));
}

}  // namespace

DCA_SUBCOMMAND("lua", "run a Lua file with the dca modules on the path",
               "usage: dca lua FILE [args...]\n\n"
               "Runs FILE in dca's embedded Lua 5.4 with `require \"dca.<module>\"` and `require \"lpeg\"` available.\n"
               "The global `arg` holds FILE (arg[0]) and the args, which are also passed as `...`.\n"
               "Exit code: the chunk's integer result, 0 when it returns nothing or true, 1 for false or on an error\n"
               "(printed as file:line: message with a traceback).",
               cmd_lua);

}  // namespace dca::cli::cmd_lua
