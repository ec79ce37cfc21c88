-- dca.lang.graph: a checked DCA model (dca.lang.model) as Graphviz DOT: the process tree, each group's
-- expression, and the connections inside each group (dotted, labelled with ports and label set).
local algebra = require "dca.algebra"
local model = require "dca.lang.model"

local M = {}

local concat, sformat, ipairs = table.concat, string.format, ipairs

-- A DOT string literal.
local function q(s)
  return '"' .. tostring(s):gsub("[\\\"]", "\\%0"):gsub("\n", "\\n") .. '"'
end

local function id(node) return q(node.path) end

--- The DOT text of the tree rooted at `tree` (a dca.lang.model node).
function M.dot(tree)
  local out = { "digraph dca {", "  rankdir=TB;", "  compound=true;",
                '  node [fontname="Helvetica", fontsize=10];', '  edge [fontname="Helvetica", fontsize=9];' }
  local function add(s) out[#out + 1] = s end
  model.walk(tree, function(n)
    if n.kind == "group" then
      local lines = { sformat("%s : %s", n.name, n.type) }
      if n.host ~= nil then lines[#lines + 1] = "host " .. tostring(n.host) end
      local act = n.process.actions
      if act and act.expr then lines[#lines + 1] = algebra.tostring(act.expr) end
      add(sformat("  %s [shape=folder, style=filled, fillcolor=\"#e8eef8\", label=%s];", id(n), q(concat(lines, "\n"))))
    else
      local lines = { sformat("%s : %s", n.name, n.type), "@" .. tostring(n.host) }
      if #n.params > 0 then
        local ps = {}
        for i, v in ipairs(n.params) do ps[i] = type(v) == "string" and sformat("%q", v) or tostring(v) end
        lines[#lines + 1] = "(" .. concat(ps, ", ") .. ")"
      end
      add(sformat("  %s [shape=box, label=%s];", id(n), q(concat(lines, "\n"))))
    end
    if n.parent then add(sformat("  %s -> %s;", id(n.parent), id(n))) end
  end)
  model.walk(tree, function(n)
    if n.kind ~= "group" then return end
    for _, set in ipairs(n.process.internal_connections) do
      for _, c in ipairs(set.connections) do
        local from, to = n.children[c.from], n.children[c.to]
        if from and to then
          add(sformat("  %s -> %s [style=dotted, constraint=false, color=\"#886600\", label=%s];", id(from), id(to),
                      q(sformat("%s -> %s [%s]", c.out, c["in"], set.label))))
        end
      end
    end
  end)
  add("}")
  return concat(out, "\n") .. "\n"
end

return M
