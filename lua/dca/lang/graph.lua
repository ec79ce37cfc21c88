-- dca.lang.graph: a checked DCA model (dca.lang.model) as Graphviz DOT, laid out to be read top-down: one
-- cluster per group (its name, type, host and expression as the label), its leaves inside in rows of a few,
-- its child groups below them, and the connections inside each group as dotted edges labelled with ports and
-- label set. Invisible edges only order the rows; they carry no meaning.
local algebra = require "dca.algebra"
local model = require "dca.lang.model"

local M = {}

local concat, sformat, ipairs, type, tostring = table.concat, string.format, ipairs, type, tostring

local LEAVES_PER_ROW, GROUPS_PER_ROW, WRAP = 3, 2, 60

-- A DOT string literal; "\n" in s becomes a centred line break.
local function q(s)
  return '"' .. tostring(s):gsub("[\\\"]", "\\%0"):gsub("\n", "\\n") .. '"'
end

-- A parameter as written in the .dca file: strings quoted, config("key") as such, numbers as numbers.
local function param_text(v)
  if type(v) == "string" then return sformat("%q", v) end
  if type(v) == "table" and type(v.config) == "string" then return sformat("config(%q)", v.config) end
  return tostring(v)
end

-- `text` broken at spaces into lines of at most `width` characters (a longer word stays whole).
local function wrap(text, width)
  local lines, line = {}, ""
  for word in text:gmatch("%S+") do
    if line ~= "" and #line + 1 + #word > width then
      lines[#lines + 1] = line
      line = word
    else
      line = line == "" and word or (line .. " " .. word)
    end
  end
  if line ~= "" then lines[#lines + 1] = line end
  return concat(lines, "\n")
end

local function leaf_label(n)
  local lines = { sformat("%s : %s", n.name, n.type), "@" .. tostring(n.host) }
  if n.standby then lines[2] = lines[2] .. " (standby " .. concat(n.standby, ", ") .. ")" end
  if #n.params > 0 then
    local ps = {}
    for i, v in ipairs(n.params) do ps[i] = param_text(v) end
    lines[#lines + 1] = wrap("(" .. concat(ps, ", ") .. ")", 40)
  end
  return concat(lines, "\n")
end

local function group_label(n)
  local head = sformat("%s : %s", n.name, n.type)
  if n.host ~= nil then head = head .. " @" .. tostring(n.host) end
  if n.hosts and #n.hosts > 1 then head = head .. " (standby " .. concat(n.hosts, ", ", 2) .. ")" end
  local pol = n.supervision
  if pol then
    local on = {}
    for _, k in ipairs({ "crash", "lost", "aborted" }) do if pol.on[k] then on[#on + 1] = k end end
    head = head .. sformat("\n%s, %d in %g s, on %s", pol.strategy, pol.intensity, pol.within,
                           #on > 0 and concat(on, ", ") or "nothing")
  end
  local f, d = n.fence, model.FENCE_DEFAULTS
  if f and (f.fence ~= d.fence or f.margin ~= d.margin) then
    head = head .. sformat("\nfence %g s, margin %g s", f.fence, f.margin)
  end
  local act = n.process.actions
  if act and act.expr then head = head .. "\n" .. wrap(algebra.tostring(act.expr), WRAP) end
  return head
end

-- The children of group g in declaration order, as rows: leaves LEAVES_PER_ROW a row, then groups
-- GROUPS_PER_ROW a row.
local function rows_of(g)
  local rows, leaves, groups = {}, {}, {}
  for _, child in ipairs(g.children) do
    local list = child.kind == "group" and groups or leaves
    list[#list + 1] = child
  end
  local function chunk(list, k)
    for i = 1, #list, k do
      local row = {}
      for j = i, math.min(i + k - 1, #list) do row[#row + 1] = list[j] end
      rows[#rows + 1] = row
    end
  end
  chunk(leaves, LEAVES_PER_ROW)
  chunk(groups, GROUPS_PER_ROW)
  return rows
end

--- The DOT text of the tree rooted at `tree` (a dca.lang.model node).
function M.dot(tree)
  local out = { "digraph dca {", "  rankdir=TB;", "  compound=true;", "  ordering=out;", "  nodesep=0.5;",
                "  ranksep=0.35;", '  node [fontname="Helvetica", fontsize=10, shape=box, style=rounded];',
                '  edge [fontname="Helvetica", fontsize=9];' }
  local function add(indent, s) out[#out + 1] = string.rep("  ", indent) .. s end
  local order = {}  -- { from node id, to node id } of the invisible edges that order the rows
  local function after(froms, to)
    for _, f in ipairs(froms) do order[#order + 1] = { f, to } end
  end
  -- Emits node n (a leaf, or a group as a cluster) at `indent`; returns the id of its top node and the ids of
  -- its bottom nodes. A cluster's top is an invisible point above its first row.
  local function emit(n, indent)
    if n.kind ~= "group" then
      add(indent, sformat("%s [label=%s];", q(n.path), q(leaf_label(n))))
      return q(n.path), { q(n.path) }
    end
    add(indent, sformat("subgraph %s {", q("cluster_" .. n.path)))
    add(indent + 1, sformat('label=%s; labeljust=l; style="rounded,filled"; fillcolor="#eef2f9"; color="#7a8fb8";',
                            q(group_label(n))))
    local top = q(n.path)
    add(indent + 1, sformat("%s [shape=point, style=invis, width=0, height=0, label=\"\"];", top))
    local above, column = { top }, nil  -- column: the previous row of leaves, whose i-th is above this one's i-th
    for _, row in ipairs(rows_of(n)) do
      local below, leaves = {}, row[1].kind ~= "group"
      for i, c in ipairs(row) do
        local t, bs = emit(c, indent + 1)
        if leaves and column and column[i] then after({ column[i] }, t) else after(above, t) end
        for _, b in ipairs(bs) do below[#below + 1] = b end
      end
      above, column = below, leaves and below or nil
    end
    add(indent, "}")
    return top, above
  end
  emit(tree, 1)
  for _, e in ipairs(order) do add(1, sformat("%s -> %s [style=invis];", e[1], e[2])) end
  local function connections(n)
    if n.kind ~= "group" then return end
    for _, set in ipairs(n.process.internal_connections) do
      for _, c in ipairs(set.connections) do
        local from, to = n.children[c.from], n.children[c.to]
        if from and to then
          local attrs = { "style=dotted", "constraint=false", 'color="#886600"',
                          "xlabel=" .. q(sformat("%s -> %s [%s]", c.out, c["in"], set.label)) }
          if from.kind == "group" then attrs[#attrs + 1] = "ltail=" .. q("cluster_" .. from.path) end
          if to.kind == "group" then attrs[#attrs + 1] = "lhead=" .. q("cluster_" .. to.path) end
          add(1, sformat("%s -> %s [%s];", q(from.path), q(to.path), concat(attrs, ", ")))
        end
      end
    end
    for _, c in ipairs(n.children) do connections(c) end
  end
  connections(tree)
  add(0, "}")
  return concat(out, "\n") .. "\n"
end

return M
