-- The `dca` executable's dispatch: help, --version, unknown subcommands, per-command --help.
local T = require "dca.testing"
local suite = T.suite("cli")

suite:case("version_prints_the_release", function()
  local out = T.dca("--version", 0)
  T.ok(out:match("^dca %d+%.%d+%.%d+\n$"), "got: " .. out)
end)

suite:case("help_lists_subcommands", function()
  T.dca("help", 0, "lua ", "usage: dca <command>")
end)

suite:case("unknown_subcommand_prints_list_and_exits_2", function()
  T.dca("frobnicate", 2, "'frobnicate' is not a dca command", "commands:")
end)

suite:case("no_subcommand_exits_2", function()
  T.dca("", 2)
end)

suite:case("subcommand_help_prints_its_usage", function()
  T.dca("lua --help", 0, "usage: dca lua FILE")
  T.dca("help lua", 0, "usage: dca lua FILE")
end)

return suite:run(...)
