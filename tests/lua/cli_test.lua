-- The `dca` executable's dispatch: help, --version, unknown subcommands, per-command --help.
local T = require "dca.testing"
local suite = T.suite("cli")

local dca = os.getenv("DCA_EXE") or "dca"

suite:case("version_prints_the_release", function()
  local out, rc = T.sh(dca .. " --version")
  T.eq(rc, 0)
  T.ok(out:match("^dca %d+%.%d+%.%d+\n$"), "got: " .. out)
end)

suite:case("help_lists_subcommands", function()
  local out, rc = T.sh(dca .. " help")
  T.eq(rc, 0)
  T.contains(out, "lua ")
  T.contains(out, "usage: dca <command>")
end)

suite:case("unknown_subcommand_prints_list_and_exits_2", function()
  local out, rc = T.sh(dca .. " frobnicate")
  T.eq(rc, 2)
  T.contains(out, "'frobnicate' is not a dca command")
  T.contains(out, "commands:")
end)

suite:case("no_subcommand_exits_2", function()
  local _, rc = T.sh(dca)
  T.eq(rc, 2)
end)

suite:case("subcommand_help_prints_its_usage", function()
  local out, rc = T.sh(dca .. " lua --help")
  T.eq(rc, 0)
  T.contains(out, "usage: dca lua FILE")
  out, rc = T.sh(dca .. " help lua")
  T.eq(rc, 0)
  T.contains(out, "usage: dca lua FILE")
end)

return suite:run(...)
