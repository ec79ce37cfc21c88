-- The `dca` executable's dispatch: help, --version, unknown subcommands, per-command --help.
local T = require "dca.testing"
local suite = T.suite("cli")

-- `dca --version`: the release, and in a git checkout the commit it was built from (HEAD or one before it, when
-- commits came after the build).
suite:case("version_prints_the_release_and_its_commit", function()
  local out = T.dca("--version", 0)
  local head = T.sh("git -C " .. T.src .. " rev-parse HEAD 2>/dev/null")
  if not head:match("^%x+%s*$") then
    T.ok(out:match("^dca %d+%.%d+%.%d+\n$"), "no git: the release alone: " .. out)
    return
  end
  local commit = out:match("^dca %d+%.%d+%.%d+ %(commit (%x+)[,)]")
  T.ok(commit and #commit == 12, "dca 0.1.0 (commit <12 hex digits>[, modified]): " .. out)
  T.eq(select(2, T.sh("git -C " .. T.src .. " merge-base --is-ancestor " .. commit .. " HEAD")), 0,
    "the commit is HEAD or one before it: " .. out)
end)

-- One case a row: `dca ARGS` exits with the code, its output holding each fragment.
for _, c in ipairs({
  { "help_lists_subcommands", "help", 0, "lua ", "usage: dca <command>" },
  { "unknown_subcommand_says_so_in_two_lines_and_exits_2", "frobnicate", 2, "'frobnicate' is not a dca command",
    "`dca help` lists the commands." },
  { "a_mistyped_subcommand_gets_the_closest", "chek", 2, "'chek' is not a dca command (did you mean 'check'?)" },
  { "no_subcommand_exits_2", "", 2 },
}) do
  suite:case(c[1], function() T.dca(table.unpack(c, 2)) end)
end

suite:case("an_unknown_command_is_not_followed_by_the_whole_list", function()
  local out = T.dca("frobnicate", 2)
  T.ok(not out:find("commands:", 1, true), out)
  local lines = select(2, out:gsub("\n", ""))
  T.ok(lines <= 2, "two lines, got:\n" .. out)
end)

-- A helper module of the subcommands (dca.cli.args) is no command: not listed, not run.
suite:case("helper_modules_are_not_commands", function()
  T.ok(not T.dca("help", 0):find("\n  args ", 1, true), "args listed")
  T.dca("args", 2, "'args' is not a dca command")
end)

-- A bad option: the error with the closest options, the usage's first line and where the rest is; not the whole
-- usage (dca run's is about 40 lines).
suite:case("a_mistyped_option_gets_the_closest_and_a_short_usage", function()
  local out = T.dca("run x.dca --simm door", 2, "dca run: unknown option '--simm' (did you mean --sim?)",
                    "usage: dca run FILE.dca", "(`dca run --help`: the whole usage)")
  local lines = select(2, out:gsub("\n", ""))
  T.ok(lines <= 3, "three lines, got:\n" .. out)
end)

suite:case("subcommand_help_prints_its_usage", function()
  T.dca("lua --help", 0, "usage: dca lua FILE")
  T.dca("help lua", 0, "usage: dca lua FILE")
end)

return suite:run(...)
