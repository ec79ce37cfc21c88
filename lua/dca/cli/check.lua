-- `dca check FILE.dca`: parse and statically check a DCA system; nothing is started.
local args = require "dca.cli.args"
local load = require "dca.load"
local check = require "dca.lang.check"
local model = require "dca.lang.model"

local M = {}

M.summary = "check a .dca system file (syntax, instances, ports, expressions) without starting anything"
M.usage = [[usage: dca check FILE.dca [--root NAME] [--no-registry] [--tree] [--config FILE | --no-config]

Parses FILE.dca and runs every static check, printing all errors (file:line:col, the instance path, the
source line and a caret); exits 1 when there are errors, else prints a one-line summary and exits 0.
  --root NAME     the root process (default: main)
  --no-registry   do not ask the controller registry (dca.core.types) for port manifests; undefined
                  process types are then taken as leaves
  --tree          also print the instance tree (type, host, parameters) after the summary
  --config FILE   the system's configuration defaults (default FILE.config beside FILE.dca, when there is
                  one): a config("key") parameter whose key it lacks is a warning (the repository may hold
                  it; with a close name: a likely typo), a default of the wrong type for the parameter is an
                  error, and so is a defaults file that does not read]]

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

function M.main(argv)
  local o, err = args.parse(argv, "dca check", { ["--root"] = "value", ["--no-registry"] = "flag",
    ["--tree"] = "flag", ["--config"] = "value", ["--no-config"] = "flag" })
  if not o then return args.usage_error(err, M.usage) end
  local file, root, use_registry = o[1], o.root, not o.no_registry
  if not file then io.stderr:write(M.usage, "\n"); return 2 end
  local ast, tree = load.file(file, { root = root, registry = use_registry })
  if not ast then
    io.stderr:write(tree, "\n")
    return 1
  end
  if not tree then
    io.stdout:write(string.format("%s: ok: %s, no root process 'main'\n", file,
                                  plural(#ast.processes, "process definition")))
    return 0
  end
  -- the config("key") parameters against the system's defaults file
  local config_file = o.config or (not o.no_config and require("dca.config").defaults_file(file)) or nil
  if config_file then
    local notes = M.config_notes(ast, config_file, use_registry and load.registry() or nil)
    for _, w in ipairs(notes.warnings) do io.stderr:write(w, "\n") end
    if #notes.errors > 0 then
      io.stderr:write(table.concat(notes.errors, "\n"), "\n")
      io.stderr:write(string.format("%s: %s\n", file, plural(#notes.errors, "error")))
      return 1
    end
  end
  local s = model.summary(tree)
  io.stdout:write(string.format("%s: ok: %s, %s (%s), %s, %s (%s)\n", file, plural(s.groups, "group"),
                                plural(s.instances, "instance"), plural(s.leaves, "leaf"):gsub("leafs", "leaves"),
                                plural(s.connections, "connection"), plural(#s.hosts, "host"),
                                table.concat(s.hosts, ", ")))
  if o.tree then io.stdout:write(M.tree_text(tree)) end
  return 0
end

return M
