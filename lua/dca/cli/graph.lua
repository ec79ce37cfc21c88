-- `dca graph FILE.dca`: the process tree and each group's expression as Graphviz DOT (or SVG).
local graph = require "dca.lang.graph"
local cli_check = require "dca.cli.check"

local M = {}

M.summary = "draw a .dca system: the process tree and expressions as Graphviz DOT, or SVG"
M.usage = [[usage: dca graph FILE.dca [--root NAME] [--svg] [-o OUT] [--no-registry]

Writes the checked system's tree (groups with their host and expression, leaves with host and parameters,
connections dotted) as Graphviz DOT to stdout, or to OUT with -o. --svg renders it with `dot -Tsvg`
(graphviz; scripts/setup installs it). The file is checked as by `dca check` first (--no-registry: without
the controller registry's manifests).]]

local function shell_quote(s) return "'" .. s:gsub("'", "'\\''") .. "'" end

function M.main(args)
  local file, root, svg, out, use_registry = nil, nil, false, nil, true
  local i = 1
  while i <= args.n do
    local a = args[i]
    if a == "--root" or a == "-o" then
      local v = args[i + 1]
      if not v then io.stderr:write("dca graph: ", a, " needs a value\n", M.usage, "\n"); return 2 end
      if a == "--root" then root = v else out = v end
      i = i + 1
    elseif a == "--svg" then
      svg = true
    elseif a == "--no-registry" then
      use_registry = false
    elseif a:sub(1, 1) == "-" or file then
      io.stderr:write("dca graph: unexpected argument '", a, "'\n", M.usage, "\n")
      return 2
    else
      file = a
    end
    i = i + 1
  end
  if not file then io.stderr:write(M.usage, "\n"); return 2 end
  local ast, tree = cli_check.load(file, root, use_registry)
  if not ast then io.stderr:write(tree, "\n"); return 1 end
  if not tree then io.stderr:write("dca graph: ", file, " has no root process 'main' (use --root NAME)\n"); return 1 end
  local dot = graph.dot(tree)
  if not svg then
    if out then
      local f, err = io.open(out, "w")
      if not f then io.stderr:write("dca graph: cannot write ", tostring(err), "\n"); return 1 end
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
