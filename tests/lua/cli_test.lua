-- The `dca` executable's dispatch: help, --version, unknown subcommands, per-command --help.
local T = require "dca.testing"
local suite = T.suite("cli")

suite:case("version_prints_the_release", function()
  local out = T.dca("--version", 0)
  T.ok(out:match("^dca %d+%.%d+%.%d+\n$"), "got: " .. out)
end)

-- One case a row: `dca ARGS` exits with the code, its output holding each fragment.
for _, c in ipairs({
  { "help_lists_subcommands", "help", 0, "lua ", "usage: dca <command>" },
  { "unknown_subcommand_prints_list_and_exits_2", "frobnicate", 2, "'frobnicate' is not a dca command", "commands:" },
  { "no_subcommand_exits_2", "", 2 },
}) do
  suite:case(c[1], function() T.dca(table.unpack(c, 2)) end)
end

suite:case("subcommand_help_prints_its_usage", function()
  T.dca("lua --help", 0, "usage: dca lua FILE")
  T.dca("help lua", 0, "usage: dca lua FILE")
end)

return suite:run(...)
