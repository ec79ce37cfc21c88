-- dca.cli.args: the subcommands' one argument parser.
local T = require "dca.testing"
local args = require "dca.cli.args"
local suite = T.suite("args")

local OPTIONS = { ["--root"] = "value", ["-o"] = "value:out", ["--svg"] = "flag", ["--no-registry"] = "flag",
                  ["--seed"] = "number", ["--set"] = "list" }

local function parse(...) return args.parse(table.pack(...), "dca x", OPTIONS) end

suite:case("options_and_positionals", function()
  local o = assert(parse("f.dca", "--root", "R", "-o", "out.dot", "--svg", "--no-registry", "--seed", "7",
                         "--set", "a=1", "--set", "b=2"))
  T.eq(o, { n = 1, "f.dca", root = "R", out = "out.dot", svg = true, no_registry = true, seed = 7,
            set = { "a=1", "b=2" } })
end)

suite:case("errors_name_the_command_and_the_option", function()
  T.eq({ parse("--root") }, { nil, "dca x: --root needs a value" })
  T.eq({ parse("--seed", "soon") }, { nil, "dca x: --seed needs a number" })
  T.eq({ parse("--frob") }, { nil, "dca x: unknown option '--frob'" })
  T.eq({ parse("--rot") }, { nil, "dca x: unknown option '--rot' (did you mean --root?)" })
  T.eq({ parse("--se") }, { nil, "dca x: unknown option '--se' (did you mean --seed or --set?)" })
  T.eq({ parse("--no-reg") }, { nil, "dca x: unknown option '--no-reg' (did you mean --no-registry?)" })
  T.eq({ parse("a.dca", "b.dca") }, { nil, "dca x: unexpected argument 'b.dca'" })
  T.eq({ parse("-") }, { nil, "dca x: unknown option '-' (did you mean -o?)" })
end)

suite:case("more_positionals_when_allowed", function()
  local o = assert(args.parse({ "set", "a=1", "b=2", "--key", "k", n = 5 }, "dca config", { ["--key"] = "value" },
                              math.huge))
  T.eq(o, { n = 3, "set", "a=1", "b=2", key = "k" })
end)

return suite:run(...)
