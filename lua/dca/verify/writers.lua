-- dca.verify.writers: at most one writer per actuator (docs/verify.md, "One writer per input"). The inputs it
-- covers: every device command input (a world's input, named by the device output ports of the leaves that
-- write it; the inputs of one actuator, a joint's alias and its drive's vector, are one: `actuators`) and every
-- input a process declares `exclusive INST.PORT` in its verify section. A writer is one
-- route into the input: a leaf's device output, or a connection (through external_io) from a leaf's output.
-- It writes while its conditions hold together: its leaf runs, and for a connection its set is active (the
-- set's owner runs with that label in the set's group).
--
-- A query is a list of conditions { group = <group node>, name = <operand name | "owner[label]"> } that must
-- hold in one reachable state of the whole tree. It is answered from the groups' own explorations: below the
-- groups' lowest common ancestor L, each group on the way must run the next one (and hold its own names) in
-- one state of its exploration. Every state of a child's exploration can be reached while its parent stays in
-- a state that runs it (the parent's other events can wait), and a restart (docs/supervision.md) neither runs
-- what the expression does not run nor starts a sub-group anywhere but at its exploration's first state: so
-- the states of the tree are exactly these combinations, and the traces together are a run.
--
--   local writers = require "dca.verify.writers"
--   local plan = writers.plan(tree, conns, decls, actuators) -- the inputs, their writers, the queries to watch
--   writers.needs(plan)   --> [process name] = { { key, names } ... }: what each group's exploration records
--   writers.findings(plan, memo) --> per group process name: { writers = {...}, dead_paths = {...}, claims = {...} }
local ports = require "dca.lang.ports"
local model = require "dca.lang.model"

local M = {}

local ipairs, pairs, tostring, sformat, concat, sort = ipairs, pairs, tostring, string.format, table.concat, table.sort

-- The conditions under which a leaf runs: its own name in its group.
local function runs(leaf) return { group = leaf.parent, name = leaf.name } end

-- The condition under which connection c's set is active: its owner runs with its label.
local function active(c) return { group = c.group, name = c.owner .. "[" .. c.label .. "]" } end

-- The robot's emergency stop (docs/safety.md): an input, not an actuator; any number of buttons may press it.
local ESTOP = "estop"

-- The device command inputs: signal -> { writers }, each { who = "PATH.PORT", leaf, conds }.
local function device_writers(tree, inputs, order, actuators)
  model.walk(tree, function(n)
    if n.kind ~= "leaf" or not n.manifest then return end
    for _, p in ipairs(n.manifest.outputs or {}) do
      if p.device and p.device ~= "" then
        local signal = ports.device_signal(p.device, n.manifest.params, n.params)
        if signal and signal ~= ESTOP then
          local key = "world." .. (actuators[signal] or signal)
          if not inputs[key] then inputs[key] = { name = key, writers = {}, device = true } order[#order + 1] = key end
          local list = inputs[key].writers
          list[#list + 1] = { who = n.path .. "." .. p.name, leaf = n, conds = { runs(n) } }
        end
      end
    end
  end)
end

-- The inputs declared `exclusive INST.PORT` (decls: { { node = group node, prop } }), each resolved to the leaf
-- input behind it, with the connections into that leaf input as writers.
local function declared_writers(conns, decls, inputs, order)
  for _, d in ipairs(decls) do
    local leaf, port = model.resolve(d.node, d.prop.a.text, d.prop.port.text)
    if leaf then
      local key = leaf.path .. "." .. port
      if not inputs[key] then
        inputs[key] = { name = key, writers = {}, shown = d.node.path .. "." .. d.prop.a.text .. "." .. d.prop.port.text }
        order[#order + 1] = key
        for _, c in ipairs(conns) do
          if c.to == leaf and c["in"] == port then
            local list = inputs[key].writers
            list[#list + 1] = { who = c.from.path .. "." .. c.out, leaf = c.from, set = c.set,
                                conds = { runs(c.from), active(c) } }
          end
        end
      end
    end
  end
end

-- The depth of a node (the root: 0).
local function depth(n)
  local k = 0
  while n.parent do n, k = n.parent, k + 1 end
  return k
end

-- A query of conditions: the lowest group L above them all, and what must hold together in each group from L
-- down ({ [group node] = { names set } } and the groups in preorder).
local function query(conds)
  local L = conds[1].group
  for _, c in ipairs(conds) do
    local g = c.group
    while depth(g) > depth(L) do g = g.parent end
    while depth(L) > depth(g) do L = L.parent end
    while g ~= L do g, L = g.parent, L.parent end
  end
  local need, groups = {}, {}
  local function add(g, name)
    if not need[g] then need[g] = {} groups[#groups + 1] = g end
    need[g][name] = true
  end
  for _, c in ipairs(conds) do
    add(c.group, c.name)
    local g = c.group
    while g ~= L do add(g.parent, g.name) g = g.parent end
  end
  sort(groups, function(a, b) return a.path < b.path end)  -- preorder: a parent before its children
  local q = { at = L, groups = groups, keys = {} }
  for _, g in ipairs(groups) do
    local names = {}
    for n in pairs(need[g]) do names[#names + 1] = n end
    sort(names)
    q.keys[g] = { key = concat(names, "&"), names = names }
  end
  return q
end

-- The longest command path followed up from a drive, in connections (a chain of controllers feeding it).
local MAX_HOPS = 4

-- The command paths into each device writer: the writer itself (it must run), then every chain of connections
-- that ends at it, up to MAX_HOPS long, each leaf on it running and each connection's set active in one state.
-- A chain's `parent` is the chain one hop shorter that it extends.
local function command_paths(conns, inputs, order)
  local out, into = {}, {}
  for _, c in ipairs(conns) do
    into[c.to] = into[c.to] or {}
    into[c.to][#into[c.to] + 1] = c
  end
  local function walk(key, leaf, conds, text, parent, depth, seen)
    for _, c in ipairs(into[leaf] or {}) do
      if not seen[c.from] then
        local cs = { runs(c.from), active(c) }
        for _, x in ipairs(conds) do cs[#cs + 1] = x end
        local hop = sformat("%s.%s -> %s.%s", c.from.path, c.out, c.to.path, c["in"])
        local entry = { input = key, path = text and (hop .. "; " .. text) or hop, set = c.set, q = query(cs),
                        parent = parent, hops = depth }
        out[#out + 1] = entry
        if depth < MAX_HOPS then
          seen[c.from] = true
          walk(key, c.from, cs, entry.path, entry, depth + 1, seen)
          seen[c.from] = nil
        end
      end
    end
  end
  for _, key in ipairs(order) do
    local inp = inputs[key]
    if inp.device then
      for _, w in ipairs(inp.writers) do
        local entry = { input = key, path = w.who, q = query({ runs(w.leaf) }), actuator = w.leaf.path }
        out[#out + 1] = entry
        walk(key, w.leaf, { runs(w.leaf) }, nil, entry, 1, { [w.leaf] = true })
      end
    end
  end
  return out
end

--- The inputs, their writers and the queries: { inputs, order, pairs = { { input, a, b, q } }, paths, claims }.
--- decls: the `exclusive` properties { { node, prop } ... }; actuators: { [world input] = the input whose
--- actuator it drives } (nil: none).
function M.plan(tree, conns, decls, actuators)
  local inputs, order = {}, {}
  device_writers(tree, inputs, order, actuators or {})
  declared_writers(conns, decls, inputs, order)
  local plan = { inputs = inputs, order = order, pairs = {}, claims = {}, decls = decls }
  for _, key in ipairs(order) do
    local ws, groups, gorder = inputs[key].writers, {}, {}
    for i = 1, #ws do
      for j = i + 1, #ws do
        if ws[i].who ~= ws[j].who then
          local conds = {}
          for _, c in ipairs(ws[i].conds) do conds[#conds + 1] = c end
          for _, c in ipairs(ws[j].conds) do conds[#conds + 1] = c end
          plan.pairs[#plan.pairs + 1] = { input = inputs[key], a = ws[i], b = ws[j], q = query(conds) }
        end
      end
      local g = ws[i].leaf.parent
      if not groups[g] then groups[g] = {} gorder[#gorder + 1] = g end
      groups[g][#groups[g] + 1] = ws[i].who
    end
    if inputs[key].device and #gorder > 1 then
      local conds = {}
      for _, w in ipairs(ws) do conds[#conds + 1] = runs(w.leaf) end
      plan.claims[#plan.claims + 1] = { input = key, groups = gorder, by = groups, q = query(conds) }
    end
  end
  plan.paths = command_paths(conns, inputs, order)
  return plan
end

--- What each group's exploration must record: [process name] = { { key, names } ... } (a state where all the
--- names are active), from every query of the plan.
function M.needs(plan)
  local out, seen = {}, {}
  local function add(q)
    for _, g in ipairs(q.groups) do
      local def, k = g.process.name, q.keys[g]
      out[def] = out[def] or {}
      seen[def] = seen[def] or {}
      if not seen[def][k.key] then
        seen[def][k.key] = true
        out[def][#out[def] + 1] = k
      end
    end
  end
  for _, p in ipairs(plan.pairs) do add(p.q) end
  for _, p in ipairs(plan.paths) do add(p.q) end
  return out
end

-- The answer to query q from the explorations (memo: process name -> r): { trace, inner } when it holds in a
-- reachable state, "unknown" when not found in a partial exploration, nil when it never holds.
local function answer(q, memo)
  local inner, trace, partial = {}, nil, false
  for _, g in ipairs(q.groups) do
    local r = memo[g.process.name]
    local t = r and r.together and r.together[q.keys[g].key]
    partial = partial or (r and r.partial)
    if not t then return partial and "unknown" or nil end
    if g == q.at then trace = t else inner[#inner + 1] = { r = r, path = g.path, trace = t } end
  end
  if not trace then  -- L needs nothing of its own (a single group below it): it runs that group
    return nil
  end
  return { trace = trace, inner = inner }
end
M.answer = answer

-- The paths that must run in the state a query's answer reaches (its conditions' leaves and set owners).
local function must_run(conds)
  local out, seen = {}, {}
  for _, c in ipairs(conds) do
    local path = c.group.path .. "." .. c.name:match("^[^%[]+")
    if not seen[path] then seen[path] = true out[#out + 1] = path end
  end
  return out
end

local function at(list, r) list[r] = list[r] or { writers = {}, dead_paths = {}, claims = {}, unknown = {} } return list[r] end

--- The findings of the plan, by the group (its result r) they are reported at: [r] = { writers = { { input,
--- a, b, why, trace, inner, running } }, dead_paths = { { input, path, set } }, claims = { { input, text } },
--- unknown = { text } }. A finding is reported once per process definition (the first instance's paths).
function M.findings(plan, memo)
  local out, seen = {}, {}
  local function once(r, key)
    local k = r.type .. "\0" .. key
    if seen[k] then return false end
    seen[k] = true
    return true
  end
  for _, p in ipairs(plan.pairs) do
    local r = memo[p.q.at.process.name]
    local a = answer(p.q, memo)
    local shown = p.input.shown or p.input.name
    local rel = p.a.who:sub(#p.q.at.path + 2) .. "\0" .. p.b.who:sub(#p.q.at.path + 2) .. "\0" .. shown:sub(#p.q.at.path + 2)
    if a == "unknown" then
      if once(r, "u" .. rel) then
        local u = at(out, r).unknown
        u[#u + 1] = sformat("whether %s and %s can write %s together (not in the part explored)", p.a.who, p.b.who, shown)
      end
    elseif a and once(r, rel) then
      local conds = {}
      for _, c in ipairs(p.a.conds) do conds[#conds + 1] = c end
      for _, c in ipairs(p.b.conds) do conds[#conds + 1] = c end
      local w = at(out, r).writers
      w[#w + 1] = { input = shown, a = p.a.who, b = p.b.who, trace = a.trace, inner = a.inner, running = must_run(conds),
                    why = sformat("%s is written by %s and %s in the same state", shown, p.a.who, p.b.who) }
    end
  end
  local dead = {}
  for _, p in ipairs(plan.paths) do
    local r = memo[p.q.at.process.name]
    local a = answer(p.q, memo)
    if a == nil then dead[p] = true end
    if p.parent and dead[p.parent] then  -- a longer chain through a dead one: that one is reported
      dead[p] = true
    elseif a == nil and once(r, "d" .. p.path .. tostring(p.set)) then
      local d = at(out, r).dead_paths
      d[#d + 1] = { input = p.input, path = p.path, set = p.set, actuator = p.actuator, hops = p.hops }
    elseif a == "unknown" and once(r, "du" .. p.path .. tostring(p.set)) then
      local u = at(out, r).unknown
      u[#u + 1] = sformat("whether the command path %s can reach %s (not in the part explored)", p.path, p.input)
    end
  end
  for _, c in ipairs(plan.claims) do
    local r = memo[c.q.at.process.name]
    local parts = {}
    for _, g in ipairs(c.groups) do parts[#parts + 1] = sformat("%s (%s)", g.path, concat(c.by[g], ", ")) end
    if once(r, "c" .. c.input) then
      local list = at(out, r).claims
      list[#list + 1] = { input = c.input, text = concat(parts, " and ") }
    end
  end
  return out
end

return M
