-- `dca graph FILE.dca`: the process tree and each group's expression as Graphviz DOT (or SVG).
local args = require "dca.cli.args"
local graph = require "dca.lang.graph"
local load = require "dca.load"

local M = {}

M.summary = "draw a .dca system as Graphviz DOT or SVG: the tree (--flow: the data flow), ports, hosts, the world"
M.usage = [[usage: dca graph FILE.dca [--root NAME] [--svg] [-o OUT] [--flow] [--no-registry] [--sim WORLD]

Writes the checked system's tree top-down (each group a cluster labelled with its host and expression, its leaves
inside with host and parameters as written, its child groups below them). Each leaf has a port per
input (top) and output (bottom), filled with its host's colour (a legend names the hosts); each connection is
an edge from an output port to an input port, labelled with its label set. The world (with --sim, or when a
leaf has device ports) is a node with its device signals, wired to the leaves' device ports. --flow: the data
flow only (the leaves, the world and the connections, ranked by the data flow, no groups). Output
as Graphviz DOT to stdout, or to OUT with -o. --svg renders it with `dot -Tsvg`
(graphviz; scripts/setup installs it). The file is checked as by `dca check` first (--no-registry: without
the controller registry's manifests; --sim WORLD: its device ports against that world, default door).]]

local function shell_quote(s) return "'" .. s:gsub("'", "'\\''") .. "'" end

function M.main(argv)
  local o, err = args.parse(argv, "dca graph", { ["--root"] = "value", ["-o"] = "value:out", ["--svg"] = "flag", ["--flow"] = "flag",
    ["--no-registry"] = "flag", ["--sim"] = "value" })
  if not o then return args.usage_error(err, M.usage) end
  local file, out, svg = o[1], o.out, o.svg
  if not file then io.stderr:write(M.usage, "\n"); return 2 end
  local ast, tree = load.file(file, { root = o.root, registry = not o.no_registry, world = o.sim })
  if not ast then io.stderr:write(tree, "\n"); return 1 end
  if not tree then io.stderr:write("dca graph: ", file, " has no root process 'main' (use --root NAME)\n"); return 1 end
  local dot = graph.dot(tree, { flow = o.flow, world = o.sim })
  if not svg then
    if out then
      local f, werr = io.open(out, "w")
      if not f then io.stderr:write("dca graph: cannot write ", tostring(werr), "\n"); return 1 end
      f:write(dot)
      f:close()
    else
      io.stdout:write(dot)
    end
    return 0
  end
  local have = os.execute("command -v dot >/dev/null 2>&1")
  if not have then
    io.stderr:write("dca graph: --svg needs Graphviz's `dot`, which is not installed (scripts/setup installs graphviz)\n")
    return 1
  end
  local tmp = os.tmpname()
  local f = assert(io.open(tmp, "w"))
  f:write(dot)
  f:close()
  local cmd = "dot -Tsvg " .. shell_quote(tmp) .. (out and (" -o " .. shell_quote(out)) or "")
  local ok = os.execute(cmd)
  os.remove(tmp)
  if not ok then io.stderr:write("dca graph: dot failed\n"); return 1 end
  return 0
end

return M
