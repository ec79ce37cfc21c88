-- `dca check FILE.dca`: parse and statically check a DCA system; nothing is started.
local args = require "dca.cli.args"
local load = require "dca.load"
local check = require "dca.lang.check"
local model = require "dca.lang.model"

local M = {}

M.summary = "check a .dca system file (syntax, instances, ports, expressions) without starting anything"
M.usage = [==[usage: dca check FILE.dca [--root NAME] [--no-registry] [--tree] [--config FILE | --no-config]
                 [--sim WORLD] [--verify [--no-faults] [--traces] [--emit-scenario FILE.lua] [--promela] [--max-states N]]

Parses FILE.dca and runs every static check, printing all errors (file:line:col, the instance path, the
source line and a caret); exits 1 when there are errors, else prints a one-line summary and exits 0.
  --root NAME     the root process (default: main)
  --no-registry   do not ask the controller registry (dca.core.types) for port manifests; undefined
                  process types are then taken as leaves
  --tree          also print the instance tree (type, host, parameters) after the summary
  --sim WORLD     the world whose signals the leaves' device ports are held to, as `dca run --sim WORLD`
                  takes it: door (the default), ROBOT.urdf or mock:ROBOT.urdf (its joints' ports, from the
                  file: docs/robots.md); a device port whose signal the world lacks, or of another size,
                  is an error at the leaf, and so is a URDF that does not load, at its own file:line
  --config FILE   the system's configuration defaults (default FILE.config beside FILE.dca, when there is
                  one): a config("key") parameter whose key it lacks is a warning (the repository may hold
                  it; with a close name: a likely typo), a default of the wrong type for the parameter is an
                  error, and so is a defaults file that does not read
  --verify        explore every run of every group's expression with the algebra engine (a leaf does what
                  its type's manifest says: `dca types`, ends) and report, per group, how it can end (DONE
                  with which value, ABORTED with which reasons), states where it is stuck, operands that can
                  never start, connection sets active together that feed one input twice, and the
                  properties of its verify { } section, each finding with a shortest trace; exits 1 when a
                  property is violated, else 3 when the exploration stopped at --max-states (a partial
                  exploration: every verdict it could not establish is "unknown")
  --no-faults     leave out crashes and lost hosts (by default any process can crash, any host be lost)
  --traces        also print a trace to every outcome
  --emit-scenario FILE.lua  write the first counter-example as a scenario `dca scenario` replays
  --promela       print the expression model as Promela (spin) instead of the report
  --max-states N  stop exploring a group after N states (default 500000; the report then says it is partial,
                  and so is every group above it)]==]

--- The instance tree as indented text: "name : Type @host (params)" per line; groups show their expression.
function M.tree_text(tree)
  local algebra = require "dca.algebra"
  local out = {}
  model.walk(tree, function(n, depth)
    local parts = { string.rep("  ", depth), n.name, " : ", n.type }
    if n.host ~= nil then parts[#parts + 1] = " @" .. tostring(n.host) end
    if n.kind == "leaf" and #n.params > 0 then
      local ps = {}
      for i, v in ipairs(n.params) do
        ps[i] = type(v) == "string" and string.format("%q", v)
          or (type(v) == "table" and v.config and string.format("config(%q)", v.config)) or tostring(v)
      end
      parts[#parts + 1] = " (" .. table.concat(ps, ", ") .. ")"
    elseif n.kind == "group" and n.process.actions and n.process.actions.expr then
      parts[#parts + 1] = "  { " .. algebra.tostring(n.process.actions.expr) .. " }"
    end
    out[#out + 1] = table.concat(parts)
  end)
  return table.concat(out, "\n") .. "\n"
end

--- The config("key") parameters of FILE against its defaults file (dca.lang.check.config_keys); a defaults
--- file that does not read is an error. --> { warnings = {...}, errors = {...} }
function M.config_notes(ast, config_path, registry)
  local defaults, err = require("dca.config").read_file(config_path)
  if not defaults then return { warnings = {}, errors = { err } } end
  return check.config_keys(ast, defaults, config_path, registry)
end

local function plural(n, one) return n == 1 and ("1 " .. one) or (n .. " " .. one .. "s") end

-- Diagnostics to stderr, in colour on a terminal (dca.cli.colour).
local function diag(text)
  local colour = require "dca.cli.colour"
  io.stderr:write(colour.on(2) and colour.diag(text) or text, "\n")
end

function M.main(argv)
  local o, err = args.parse(argv, "dca check", { ["--root"] = "value", ["--no-registry"] = "flag",
    ["--tree"] = "flag", ["--sim"] = "value", ["--config"] = "value", ["--no-config"] = "flag", ["--verify"] = "flag",
    ["--no-faults"] = "flag", ["--traces"] = "flag", ["--emit-scenario"] = "value", ["--promela"] = "flag",
    ["--max-states"] = "number" })
  if not o then return args.usage_error(err, M.usage) end
  local file, root, use_registry = o[1], o.root, not o.no_registry
  if not file then io.stderr:write(M.usage, "\n"); return 2 end
  local ast, tree = load.file(file, { root = root, registry = use_registry, world = o.sim })
  if not ast then
    diag(tree)
    return 1
  end
  if not tree then
    io.stdout:write(string.format("%s: ok: %s, no root process 'main'\n", file,
                                  plural(#ast.processes, "process definition")))
    if o.verify then
      io.stderr:write(file, ": --verify explores from a root process: none is named 'main' (--root NAME)\n")
      return 1
    end
    return 0
  end
  -- the config("key") parameters against the system's defaults file
  local config_file = o.config or (not o.no_config and require("dca.config").defaults_file(file)) or nil
  if config_file then
    local notes = M.config_notes(ast, config_file, use_registry and load.registry() or nil)
    for _, w in ipairs(notes.warnings) do io.stderr:write(w, "\n") end
    if #notes.errors > 0 then
      diag(table.concat(notes.errors, "\n") .. "\n" .. string.format("%s: %s", file, plural(#notes.errors, "error")))
      return 1
    end
  end
  local s = model.summary(tree)
  -- with --promela, standard output is the model alone (spin reads it): the summary goes to standard error
  local say = (o.verify and o.promela) and io.stderr or io.stdout
  say:write(string.format("%s: ok: %s, %s (%s)%s, %s, %s (%s)\n", file, plural(s.groups, "group"),
                                plural(s.instances, "instance"), plural(s.leaves, "leaf"):gsub("leafs", "leaves"),
                                s.templates > 0 and ", " .. plural(s.templates, "template") or "",
                                plural(s.connections, "connection"), plural(#s.hosts, "host"),
                                table.concat(s.hosts, ", ")))
  if o.tree then say:write(M.tree_text(tree)) end
  if o.verify then return M.verify(file, ast, tree, o) end
  return 0
end

--- The command inputs of world `spec` (nil: the default) that drive another input's actuator (a joint's alias
--- beside its drive's vector, docs/worlds.md): { [input] = actuator input }, empty without the worlds.
function M.actuators(spec)
  local ok, core = pcall(require, "dca.core")
  local s = ok and type(core.world_signals) == "function" and core.world_signals(spec or "") or nil
  return s and s.actuators or {}
end

--- `--verify`: the report (or the Promela model), the emitted scenario; 1 when a property is violated, else 3
--- when a group was explored only in part (docs/verify.md "Exit codes").
function M.verify(file, ast, tree, o)
  local verify = require "dca.verify"
  local result, errs = verify.system(tree, { faults = not o.no_faults, ast = ast, max_states = o.max_states,
                                            actuators = M.actuators(o.sim) })
  if not result then
    diag(check.format_all(ast, errs))
    return 1
  end
  if o.promela then
    io.stdout:write(require("dca.verify.promela").system(result))
    return 0
  end
  local text, _, violated, _, partial = require("dca.verify.report").text(result, { file = file, traces = o.traces })
  io.stdout:write(text)
  if o.emit_scenario then
    local ok, werr = require("dca.verify.scenario").write(o.emit_scenario, result, file, o.root)
    if not ok then io.stderr:write(werr, "\n") return 1 end
    io.stdout:write(o.emit_scenario, ": ", ok, "\n")
  end
  if violated > 0 then return 1 end
  return partial > 0 and 3 or 0
end

return M
