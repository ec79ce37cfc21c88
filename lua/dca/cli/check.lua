-- `dca check FILE.dca`: parse and statically check a DCA system; nothing is started.
local parser = require "dca.parser"
local check = require "dca.check"
local model = require "dca.model"

local M = {}

M.summary = "check a .dca system file (syntax, instances, ports, expressions) without starting anything"
M.usage = [[usage: dca check FILE.dca [--root NAME] [--no-registry] [--tree]

Parses FILE.dca and runs every static check, printing all errors (file:line:col, the instance path, the
source line and a caret); exits 1 when there are errors, else prints a one-line summary and exits 0.
  --root NAME     the root process (default: main)
  --no-registry   do not ask the controller registry (dca.core.types) for port manifests; undefined
                  process types are then taken as leaves
  --tree          also print the instance tree (type, host, parameters) after the summary]]

--- The controller registry's manifests, when dca.core provides them (nil otherwise).
function M.registry()
  local ok, core = pcall(require, "dca.core")
  if ok and type(core) == "table" and type(core.types) == "function" then
    local ok2, types = pcall(core.types)
    if ok2 and type(types) == "table" then return types end
  end
  return nil
end

--- Reads, parses, checks and builds FILE; returns ast, tree (tree nil when there is no root), or nil, text.
function M.load(path, root, use_registry)
  local f, ferr = io.open(path, "rb")
  if not f then return nil, "dca: cannot read " .. tostring(ferr) end
  local text = f:read("a")
  f:close()
  local ast, perr = parser.parse(text, path)
  if not ast then return nil, perr end
  local opts = { root = root, types = use_registry and M.registry() or nil }
  if not root and not ast.by_name.main then
    local errors = check.check(ast, opts)
    if #errors > 0 then return nil, check.format_all(ast, errors) end
    return ast, nil
  end
  local tree, errors = model.build(ast, opts)
  if not tree then return nil, check.format_all(ast, errors) end
  return ast, tree
end

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

local function plural(n, one) return n == 1 and ("1 " .. one) or (n .. " " .. one .. "s") end

function M.main(args)
  local file, root, use_registry, show_tree = nil, nil, true, false
  local i = 1
  while i <= args.n do
    local a = args[i]
    if a == "--root" then
      root = args[i + 1]
      if not root then io.stderr:write("dca check: --root needs a process name\n", M.usage, "\n"); return 2 end
      i = i + 1
    elseif a == "--no-registry" then
      use_registry = false
    elseif a == "--tree" then
      show_tree = true
    elseif a:sub(1, 1) == "-" or file then
      io.stderr:write("dca check: unexpected argument '", a, "'\n", M.usage, "\n")
      return 2
    else
      file = a
    end
    i = i + 1
  end
  if not file then io.stderr:write(M.usage, "\n"); return 2 end
  local ast, tree = M.load(file, root, use_registry)
  if not ast then
    io.stderr:write(tree, "\n")
    return 1
  end
  if not tree then
    io.stdout:write(string.format("%s: ok: %s, no root process 'main'\n", file,
                                  plural(#ast.processes, "process definition")))
    return 0
  end
  local s = model.summary(tree)
  io.stdout:write(string.format("%s: ok: %s, %s (%s), %s, %s (%s)\n", file, plural(s.groups, "group"),
                                plural(s.instances, "instance"), plural(s.leaves, "leaf"):gsub("leafs", "leaves"),
                                plural(s.connections, "connection"), plural(#s.hosts, "host"),
                                table.concat(s.hosts, ", ")))
  if show_tree then io.stdout:write(M.tree_text(tree)) end
  return 0
end

return M
