-- dca.lang.graph: a checked DCA model (dca.lang.model) as Graphviz DOT, laid out to be read top-down: one
-- cluster per group (its name, type, host and expression as the label), its leaves inside in rows of a few,
-- its child groups below them. Each leaf is a table with a port per input (top row) and output (bottom row),
-- filled with its host's colour (a legend names them); every connection, resolved to the leaf ports behind
-- external_io, is an edge from an output port to an input port labelled with its label set. The world (with
-- `world`, or when a leaf has device ports) is a node with a port per device signal the leaves use, wired to
-- them. Invisible edges only order the rows; they carry no meaning. opts.flow: the data flow only (the leaves
-- and the world, ranked by the data flow, no clusters).
local algebra = require "dca.algebra"
local model = require "dca.lang.model"
local ports = require "dca.lang.ports"

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

-- Text for a Graphviz HTML-like label, "\n" a line break.
local function h(s)
  return (tostring(s):gsub("[&<>\"]", { ["&"] = "&amp;", ["<"] = "&lt;", [">"] = "&gt;", ['"'] = "&quot;" })
    :gsub("\n", "<BR/>"))
end

-- A port's id in DOT: "i_" (input) or "o_" (output) and its name, letters, digits and _ only.
local function port_id(dir, name) return dir .. "_" .. tostring(name):gsub("[^%w_]", "_") end

local PALETTE = { "#cfe2f3", "#d9ead3", "#fce5cd", "#ead1dc", "#fff2cc", "#d0e0e3", "#f4cccc", "#d9d2e9",
                  "#e6e6e6", "#c9daf8" }

-- The ports of leaf n: its manifest's inputs and outputs, then any the connections name that it lacks
-- (a leaf without a manifest), each { name, device = signal | nil }.
local function leaf_ports(n, used)
  local p = { inputs = {}, outputs = {} }
  local seen = {}
  local m = n.manifest
  for _, dir in ipairs({ "inputs", "outputs" }) do
    for _, mp in ipairs(m and m[dir] or {}) do
      local dev
      if mp.device and mp.device ~= "" then
        dev = ports.device_signal(mp.device, m.params, n.params) or nil
      end
      p[dir][#p[dir] + 1] = { name = mp.name, device = dev }
      seen[dir .. mp.name] = true
    end
    for _, name in ipairs(used[dir] or {}) do
      if not seen[dir .. name] then
        seen[dir .. name] = true
        p[dir][#p[dir] + 1] = { name = name }
      end
    end
  end
  return p
end

-- A leaf as an HTML-like table: its inputs' ports on top, its name, type, host and parameters, its outputs'
-- ports below, on its host's colour.
local function leaf_html(n, p, colour)
  local cols = math.max(1, #p.inputs, #p.outputs)
  local rows = { sformat('<<TABLE BORDER="0" CELLBORDER="1" CELLSPACING="0" CELLPADDING="3" BGCOLOR="%s">', colour) }
  local function port_row(list, dir)
    if #list == 0 then return end
    local cells = {}
    for i, pt in ipairs(list) do
      local span = (i == #list) and (cols - #list + 1) or 1
      cells[#cells + 1] = sformat('<TD PORT="%s" COLSPAN="%d"><FONT POINT-SIZE="8">%s</FONT></TD>',
                                  port_id(dir, pt.name), span, h(pt.name))
    end
    rows[#rows + 1] = "<TR>" .. concat(cells) .. "</TR>"
  end
  port_row(p.inputs, "i")
  rows[#rows + 1] = sformat('<TR><TD COLSPAN="%d">%s</TD></TR>', cols, h(leaf_label(n)))
  port_row(p.outputs, "o")
  rows[#rows + 1] = "</TABLE>>"
  return concat(rows)
end

-- What the drawing needs of the tree: its connections resolved to leaf ports, each leaf's ports, the device
-- ports { leaf, dir, port, signal }, the hosts in the order the tree first names them and a colour each.
local function collect(tree)
  -- the connections resolved to leaf ports, and the ports each leaf uses
  local conns = model.connections(tree) or {}
  local used = {}
  local function use(leaf, dir, name)
    local u = used[leaf.path] or { inputs = {}, outputs = {} }
    used[leaf.path] = u
    u[dir][#u[dir] + 1] = name
  end
  for _, c in ipairs(conns) do use(c.from, "outputs", c.out) use(c.to, "inputs", c["in"]) end
  -- the hosts in the order the tree first names them, each a colour
  local hosts, colour = {}, {}
  local leaf_p, devices = {}, {}
  model.walk(tree, function(n)
    if n.kind == "group" then return end
    local host = tostring(n.host)
    if not colour[host] then
      hosts[#hosts + 1] = host
      colour[host] = PALETTE[(#hosts - 1) % #PALETTE + 1]
    end
    leaf_p[n.path] = leaf_ports(n, used[n.path] or {})
    for _, dir in ipairs({ "inputs", "outputs" }) do
      for _, pt in ipairs(leaf_p[n.path][dir]) do
        if pt.device then devices[#devices + 1] = { leaf = n, dir = dir, port = pt.name, signal = pt.device } end
      end
    end
  end)
  return conns, leaf_p, devices, hosts, colour
end

-- The world's node: a port per device signal the leaves use, sensors then commands.
local function world_node(devices, world)
  local sensors, commands, seen = {}, {}, {}
  for _, d in ipairs(devices) do
    local list = d.dir == "inputs" and sensors or commands
    if not seen[d.dir .. d.signal] then seen[d.dir .. d.signal] = true list[#list + 1] = d.signal end
  end
  table.sort(sensors) table.sort(commands)
  local cells = {}
  for _, sig in ipairs(sensors) do
    cells[#cells + 1] = sformat('<TD PORT="%s" BGCOLOR="#e8f4e8"><FONT POINT-SIZE="8">%s</FONT></TD>',
                                port_id("s", sig), h(sig))
  end
  for _, sig in ipairs(commands) do
    cells[#cells + 1] = sformat('<TD PORT="%s" BGCOLOR="#f8e8e8"><FONT POINT-SIZE="8">%s</FONT></TD>',
                                port_id("c", sig), h(sig))
  end
  local head = "world" .. (world and (": " .. tostring(world)) or "")
  return sformat('"world" [label=<<TABLE BORDER="0" CELLBORDER="1" CELLSPACING="0" CELLPADDING="3" '
    .. 'BGCOLOR="#ffffff"><TR><TD COLSPAN="%d"><B>%s</B><BR/><FONT POINT-SIZE="8">sensors (green), commands '
    .. '(red)</FONT></TD></TR>%s</TABLE>>];', math.max(1, #cells), h(head),
    #cells > 0 and ("<TR>" .. concat(cells) .. "</TR>") or "")
end

-- The legend: a colour per host.
local function legend(hosts, colour)
  local cells = {}
  for _, host in ipairs(hosts) do
    cells[#cells + 1] = sformat('<TR><TD BGCOLOR="%s">@%s</TD></TR>', colour[host], h(host))
  end
  return sformat('"legend" [label=<<TABLE BORDER="0" CELLBORDER="1" CELLSPACING="0" CELLPADDING="3">'
    .. '<TR><TD><B>hosts</B></TD></TR>%s</TABLE>>];', concat(cells))
end

-- The connections, output port to input port; the device ports: the world's sensors into the leaves' inputs,
-- the leaves' outputs into its commands.
local function edges(add, conns, devices)
  for _, c in ipairs(conns) do
    add(1, sformat('%s:%s:s -> %s:%s:n [color="#886600", label=%s];', q(c.from.path), port_id("o", c.out),
                   q(c.to.path), port_id("i", c["in"]), q("[" .. tostring(c.label) .. "]")))
  end
  for _, d in ipairs(devices) do
    if d.dir == "inputs" then
      add(1, sformat('"world":%s:s -> %s:%s:n [color="#3a7a3a"];', port_id("s", d.signal), q(d.leaf.path),
                     port_id("i", d.port)))
    else
      -- a command edge does not rank the world: it stays above the leaves
      add(1, sformat('%s:%s:s -> "world":%s:n [color="#aa3333", constraint=false];', q(d.leaf.path),
                     port_id("o", d.port), port_id("c", d.signal)))
    end
  end
end

--- The DOT text of the tree rooted at `tree` (a dca.lang.model node). opts: { flow = true: the data flow only;
--- world = name: a world node (shown also when a leaf has device ports) }.
function M.dot(tree, opts)
  opts = opts or {}
  local flow = opts.flow
  local out = { "digraph dca {", "  rankdir=TB;", "  compound=true;", "  ordering=out;",
                "  nodesep=0.5;", flow and "  ranksep=0.8;" or "  ranksep=0.5;",
                '  node [fontname="Helvetica", fontsize=10, shape=plain];',
                '  edge [fontname="Helvetica", fontsize=9];' }
  local function add(indent, s) out[#out + 1] = string.rep("  ", indent) .. s end
  local conns, leaf_p, devices, hosts, colour = collect(tree)
  local function leaf_node(n, indent)
    add(indent, sformat("%s [label=%s];", q(n.path), leaf_html(n, leaf_p[n.path], colour[tostring(n.host)])))
  end
  local order = {}  -- { from node id, to node id } of the invisible edges that order the rows
  local function after(froms, to)
    for _, f in ipairs(froms) do order[#order + 1] = { f, to } end
  end
  -- Emits node n (a leaf, or a group as a cluster) at `indent`; returns the id of its top node and the ids of
  -- its bottom nodes. A cluster's top is an invisible point above its first row.
  local function emit(n, indent)
    if n.kind ~= "group" then
      leaf_node(n, indent)
      return q(n.path), { q(n.path) }
    end
    add(indent, sformat("subgraph %s {", q("cluster_" .. n.path)))
    add(indent + 1, sformat('label=%s; labeljust=l; style="rounded,filled"; fillcolor="#f4f6fa"; color="#7a8fb8";',
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
    -- its templates (a fleet: docs/supervision.md, "A fleet"): one dashed box each, below its children
    local tops = {}
    for _, t in ipairs(n.templates or {}) do
      local id = q(t.path .. "[*]")
      add(indent + 1, sformat('%s [shape=box, style="dashed,rounded", label=%s];', id,
        q(sformat("%s : %s, any number of instances\n@{ %s }", t.name, t.type, concat(t.hosts, ", ")))))
      after(above, id)
      tops[#tops + 1] = id
    end
    if #tops > 0 then above = tops end
    add(indent, "}")
    return top, above
  end
  local show_world = opts.world or #devices > 0
  if show_world then add(1, world_node(devices, opts.world)) end
  if flow then
    model.walk(tree, function(n) if n.kind ~= "group" then leaf_node(n, 1) end end)
  else
    local top = emit(tree, 1)
    if show_world then after({ '"world"' }, top) end
    for _, e in ipairs(order) do add(1, sformat("%s -> %s [style=invis];", e[1], e[2])) end
  end
  edges(add, conns, devices)
  add(1, legend(hosts, colour))
  add(0, "}")
  return concat(out, "\n") .. "\n"
end

return M
