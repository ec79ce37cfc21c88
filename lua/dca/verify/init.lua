-- dca.verify: what a system's task expressions can do, proved before anything runs (`dca check --verify`).
--
--   local verify = require "dca.verify"
--   local ast, tree = require("dca.load").file("door_open.dca")
--   local result = verify.system(tree, { faults = true })
--   print(require("dca.verify.report").text(result))
--
-- Each group's internal_event_actions is explored with dca.algebra itself (dca.verify.explore), bottom up: a
-- leaf operand can do what its type's manifest says (`ends`: never, done, aborted, done or aborted; nothing
-- said: anything), plus a crash or a lost host unless faults = false; a group operand can do what its own
-- exploration found (its DONE values, its ABORTED reasons). A group is explored once per process definition
-- and its outcomes reused by every parent. A pipeline of passes over one context, like dca.lang.check:
-- operands, connection sets, properties, exploration, summary.
--
-- result = { groups = { R, ... } (children before parents), root = R, states =, transitions =, seconds = }
-- R = { type, path, node, done = { { value, trace } }, aborted = { { reason, fault, trace } }, stuck =
--       { { waiting, trace } }, never_ends, dead = { leaf expr nodes }, conflicts = { { a, b, why, trace, inner } },
--       props = { { prop, ok, trace, note } }, states, transitions, cycle }
-- A trace is a list of steps { name, ev, pick } of that group; dca.verify.trace expands it to leaf events. A
-- conflict between a set of R and a set of a group below it (the same leaf input, through external_io) has
-- inner = { { r, path, trace } ... }: from R's state where both run, the trace inside each group down to it.
local explore = require "dca.verify.explore"
local props = require "dca.verify.props"
local template = require "dca.verify.template"
local model = require "dca.lang.model"
local writers = require "dca.verify.writers"

local M = {}

local ipairs, pairs, type, tostring, tonumber, sformat, sort, clock = ipairs, pairs, type, tostring, tonumber,
  string.format, table.sort, os.clock

--- The seconds after which leaf node n ends by itself (its type's `ends_after` parameter, when the argument is a
--- number written in the file), or nil.
function M.seconds(n)
  local m = n.manifest
  if not (m and m.ends_after) then return nil end
  for i, p in ipairs(m.params or {}) do
    if p.name == m.ends_after then return type(n.params[i]) == "number" and n.params[i] or nil end
  end
  return nil
end

--- How leaf node n can end by itself: its manifest's `ends`, or "never" when its type declares a parameter value
--- that makes it never end (`never_when`, docs/packages.md) and the leaf's argument (or the default) is that value.
function M.ends(n)
  local m = n.manifest
  if not m then return nil end
  local nw = m.never_when
  if nw then
    for i, p in ipairs(m.params or {}) do
      if p.name == nw.param then
        local v = n.params[i]
        if v == nil then v = p.default end
        if v ~= nil and (tostring(v) == nw.value or tonumber(v) ~= nil and tonumber(v) == tonumber(nw.value)) then
          return "never"
        end
      end
    end
  end
  return m.ends
end

--- What a leaf operand `name` can do, from its manifest's `ends` (nil: anything), with faults or not.
function M.leaf_events(name, ends, faults)
  local ev = {}
  if ends == nil or ends == "done" or ends == "done or aborted" then
    ev[#ev + 1] = { kind = "done", value = name }
  end
  if ends == nil or ends == "aborted" or ends == "done or aborted" then
    ev[#ev + 1] = { kind = "aborted", value = name .. " aborted", reasons = { { text = name .. " aborted" } } }
  end
  if faults then
    ev[#ev + 1] = { kind = "error", value = "crash", fault = true,
                    reasons = { { text = name .. " crashed or its host was lost", fault = true } } }
  end
  return { events = ev, leaf = true, ends = ends or "undeclared" }
end

-- What a group operand can do: its outcomes, each with the inner trace that reaches it.
local function group_events(node, r, faults)
  local name, ev = node.name, {}
  for _, d in ipairs(r.done) do
    ev[#ev + 1] = { kind = "done", value = name .. "(" .. d.value .. ")", inner = d.trace, group = true }
  end
  local plain, fault = {}, {}
  for _, a in ipairs(r.aborted) do
    local item = { text = name .. "." .. a.reason, fault = a.fault, inner = a.trace }
    if a.fault then fault[#fault + 1] = item else plain[#plain + 1] = item end
  end
  if #plain > 0 then ev[#ev + 1] = { kind = "aborted", value = name .. " aborted", reasons = plain, group = true } end
  -- a group that can get stuck can, seen from its parent, stop for ever: after this event it only ends by a
  -- fault, so a parent that waits for it is stuck too (and says where, with the inner trace)
  local st = r.stuck[1]
  if st then
    ev[#ev + 1] = { kind = "stuck", value = "stuck", inner = st.trace, waiting = st.waiting, group = true, r = r }
  end
  if faults then
    for _, x in ipairs(template.fault_reasons(name, r)) do fault[#fault + 1] = x end
    fault[#fault + 1] = { text = name .. "'s supervisor or its host was lost", fault = true, lost = true }
    ev[#ev + 1] = { kind = "error", value = "lost", fault = true, reasons = fault, group = true }
  end
  return { events = ev, group = r }
end

-- The pairs of connection sets of `node` that feed one input from two writers.
local function set_conflicts(node, conns)
  local by_set = {}
  for _, c in ipairs(conns) do
    if c.group == node then
      local set = c.owner .. "[" .. c.label .. "]"
      by_set[set] = by_set[set] or {}
      local dest = c.to.path .. "." .. c["in"]
      by_set[set][#by_set[set] + 1] = { dest = dest, writer = c.from.path .. "." .. c.out }
    end
  end
  local names = {}
  for s in pairs(by_set) do names[#names + 1] = s end
  sort(names)
  local pairs_out = {}
  for i, a in ipairs(names) do
    for j = i, #names do
      local b = names[j]
      local why
      for _, x in ipairs(by_set[a]) do
        for _, y in ipairs(by_set[b]) do
          if x.dest == y.dest and x.writer ~= y.writer and not why then
            why = sformat("%s is fed by %s and %s", x.dest, x.writer, y.writer)
          end
        end
      end
      if why then pairs_out[#pairs_out + 1] = { a = a, b = b, why = why } end
    end
  end
  return pairs_out
end

-- The pairs of one set of `node` and one set of a group below it that feed one leaf input (connections resolved
-- through external_io by model.connections) from two writers. The lower set is active while the child operand
-- `b` it runs in runs and, inside it, each group of `chain` runs the next one and the last runs `target`.
local function cross_conflicts(node, conns)
  local own, below, out, seen = {}, {}, {}, {}
  local prefix = node.path .. "."
  for _, c in ipairs(conns) do
    local item = { dest = c.to.path .. "." .. c["in"], writer = c.from.path .. "." .. c.out, c = c }
    if c.group == node then own[#own + 1] = item
    elseif c.group.path:sub(1, #prefix) == prefix then below[#below + 1] = item end
  end
  for _, x in ipairs(own) do
    for _, y in ipairs(below) do
      local key = x.c.set .. "\0" .. y.c.set
      if x.dest == y.dest and x.writer ~= y.writer and not seen[key] then
        seen[key] = true
        local chain, g = {}, node
        for name in y.c.group.path:sub(#prefix + 1):gmatch("[^.]+") do
          g = g.children[name]
          chain[#chain + 1] = g
        end
        out[#out + 1] = { a = x.c.owner .. "[" .. x.c.label .. "]", b = chain[1].name, chain = chain,
                          target = y.c.owner .. "[" .. y.c.label .. "]", show_a = x.c.set, show_b = y.c.set,
                          why = sformat("%s is fed by %s and %s", x.dest, x.writer, y.writer) }
      end
    end
  end
  return out
end

-- The traces inside the groups of a cross-group conflict's chain (each a shortest one to the state that runs
-- the next group, or the lower set), or nil when one of them never runs there.
local function chain_traces(ctx, pair)
  local inner = {}
  for i, child in ipairs(pair.chain) do
    local cr = ctx.memo[child.process.name]
    local want = pair.chain[i + 1] and pair.chain[i + 1].name or pair.target
    local trace = cr and cr.first_running[want]
    if not trace then return nil end
    inner[i] = { r = cr, path = child.path, trace = trace }
  end
  return inner
end

-- The group's properties (its verify section), checked against its operands: parsed list, errors.
local function group_props(node, ast)
  local list, errors = props.of_process(node.process, { [node.name] = true })
  local out = {}
  for _, e in ipairs(errors) do
    local line, col = ast.index:at(e.pos)
    out[#out + 1] = { line = line, col = col, path = node.path, msg = e.msg }
  end
  return list, out
end

-- Whether a can_end property holds for the outcomes `done`, `aborted` (any/non-fault only).
local function can_end(p, r, operands)
  local name = p.a.text
  local d, a
  if operands[name] then
    local beh = operands[name]
    for _, ev in ipairs(r.first_running[name] and beh.events or {}) do  -- one that never starts never ends
      if ev.kind == "done" then d = true elseif not ev.fault and ev.kind ~= "stuck" then a = true end
    end
  else
    d = #r.done > 0
    for _, x in ipairs(r.aborted) do if not x.fault then a = true end end
  end
  local yes = (p.how == "done" and d) or (p.how == "aborted" and a) or (p.how == nil and (d or a))
  if p.negated then return not yes end
  return yes
end

-- The outcomes of an exploration as lists sorted by text, aborted split by reason.
local function summarize(g, operands)
  local r = { done = {}, aborted = {}, stuck = g.stuck, conflicts = {}, dead = {}, states = g.states,
              transitions = g.transitions, cycle = g.cycle, truncated = g.truncated, first_running = g.first_running,
              partial = g.truncated, unexplored = g.unexplored, reduced = g.reduced }
  for v, trace in pairs(g.done) do r.done[#r.done + 1] = { value = v, trace = trace } end
  sort(r.done, function(x, y) return x.value < y.value end)
  local seen = {}
  r.ends_by = {}
  for _, a in pairs(g.aborted) do r.ends_by[#r.ends_by + 1] = a.ev.kind .. ":" .. a.name end
  sort(r.ends_by)
  for _, a in pairs(g.aborted) do
    for k, reason in ipairs(a.ev.reasons or {}) do
      if not seen[reason.text] then
        seen[reason.text] = true
        local trace = {}
        for i, s in ipairs(a.trace) do trace[i] = s end
        local last = trace[#trace]
        trace[#trace] = { name = last.name, ev = last.ev, pick = k }
        r.aborted[#r.aborted + 1] = { reason = reason.text, fault = reason.fault, trace = trace }
      end
    end
  end
  sort(r.aborted, function(x, y)
    if x.fault ~= y.fault then return not x.fault end
    return x.reason < y.reason
  end)
  for _, c in ipairs(g.conflicts) do
    r.conflicts[#r.conflicts + 1] = { a = c.pair.show_a or c.pair.a, b = c.pair.show_b or c.pair.b, why = c.pair.why,
                                      trace = c.trace, pair = c.pair }
  end
  for _, leaf in ipairs(g.expr.leaves) do
    if not g.started[leaf.id] then r.dead[#r.dead + 1] = leaf end
  end
  local plain = #r.done > 0
  for _, a in ipairs(r.aborted) do plain = plain or not a.fault end
  r.never_ends = not plain
  -- nothing can happen from the start but a fault: a group that runs until it is stopped, like a sensor (not a
  -- finding here; a parent that waits for it gets stuck, and that is one)
  if r.stuck[1] and r.stuck[1].state == 1 then
    r.until_stopped, r.stopped_waiting, r.stuck = true, r.stuck[1].waiting, {}
  end
  r.operands = operands
  return r
end

--- A shortest trace to an end of r that is `how` ("done", "aborted" without a fault, nil: either), or nil.
function M.outcome_trace(r, how)
  local best
  local function consider(trace) if not best or #trace < #best then best = trace end end
  if how ~= "aborted" then for _, d in ipairs(r.done) do consider(d.trace) end end
  if how ~= "done" then for _, a in ipairs(r.aborted) do if not a.fault then consider(a.trace) end end end
  return best
end

--- Where group r (or a group operand below it, first in the text) gets stuck: { r = the group, stuck = its
--- first stuck state { trace, waiting } } | nil. The explanation of an end that cannot happen: when r is stuck
--- only because a group it waits on is, that group's own stuck state.
function M.stuck_below(r)
  local s = r.stuck[1]
  if s then
    for _, w in ipairs(s.waiting) do  -- stuck because a group it waits on is: where that one got stuck
      local ev = s.inside and s.inside[w]
      local below = ev and ev.r and M.stuck_below(ev.r)
      if below then return below end
    end
    return { r = r, stuck = s }
  end
  for _, leaf in ipairs(r.expr.leaves) do
    local op = r.operands[leaf.name]
    local found = op and op.group and M.stuck_below(op.group)
    if found then return found end
  end
  return nil
end

--- Explores one expression whose operands behave as `operands` (name -> { events }), with the properties
--- `list` (dca.verify.props) and the pairs of connection sets `sets` that must not be active together.
--- --> r (see the top; without type, path and node)
-- In a partial exploration, a state that waits on a group explored only in part is not proven stuck: that
-- group may end in the part of it left unexplored (r.stuck_unknown; r.until_stopped becomes r.stops_unknown).
local function doubts(r, operands)
  local function doubtful(waiting)
    for _, w in ipairs(waiting or {}) do
      local op = operands[w]
      if op and op.group and op.group.partial then return true end
    end
    return false
  end
  local keep, unknown = {}, {}
  for _, s in ipairs(r.stuck) do
    if doubtful(s.waiting) then unknown[#unknown + 1] = s else keep[#keep + 1] = s end
  end
  r.stuck, r.stuck_unknown = keep, unknown
  if r.until_stopped and doubtful(r.stopped_waiting) then r.until_stopped, r.stops_unknown = nil, true end
end

--- A partial exploration (stopped at max_states, here or in a group below) proves only what it found: a
--- violation it reached, an end it reached; every other verdict is unknown (item.ok = nil, item.unknown).
--- reduce = false: the full exploration (see dca.verify.explore).
function M.expression(expr, operands, list, sets, max_states, reduce, together)
  local monitors, mprops = {}, {}
  for _, p in ipairs(list or {}) do
    local m = props.monitor(p, operands)
    if m then monitors[#monitors + 1] = m; mprops[#mprops + 1] = p end
  end
  local g = explore.group(expr, operands, { sets = sets, monitors = monitors, max_states = max_states,
                                            reduce = reduce, together = together })
  local r = summarize(g, operands)
  r.together = g.together
  r.expr, r.props = expr, {}
  for _, op in pairs(operands) do if op.group and op.group.partial then r.partial = true end end
  local partial = r.partial
  if partial then doubts(r, operands) end
  for k, p in ipairs(mprops) do
    local v = g.violations[k]
    local item = { prop = p, ok = not v, trace = v }
    if not v and partial then item.ok, item.unknown = nil, true end
    r.props[#r.props + 1] = item
  end
  for _, p in ipairs(list or {}) do
    if p.kind == "can_end" then
      local ok = can_end(p, r, operands)
      local item = { prop = p, ok = ok, outcome = true,
                     never_starts = operands[p.a.text] and not r.first_running[p.a.text] or nil }
      if partial and (ok == (p.negated == true)) then
        item.ok, item.unknown = nil, true  -- an end not found may lie in the part left unexplored
      elseif not ok and p.negated then item.trace = M.outcome_trace(r, p.how)
      elseif not ok and not item.never_starts then item.stuck = M.stuck_below(r) end
      r.props[#r.props + 1] = item
    end
  end
  sort(r.props, function(x, y) return x.prop.pos < y.prop.pos end)
  return r
end

-- Explores one group (its children first); memoized by process definition in ctx.memo.
local function group(ctx, node)
  local def = node.process
  if ctx.memo[def.name] then return ctx.memo[def.name] end
  local operands = {}
  for _, child in ipairs(node.children) do
    if child.kind == "group" then
      operands[child.name] = group_events(child, group(ctx, child), ctx.faults)
    else
      local beh = M.leaf_events(child.name, M.ends(child), ctx.faults)
      -- (a group with a supervision policy may restart a timer: its clock starts again, so it has none here)
      beh.after = not node.supervision and M.seconds(child) or nil
      for _, ev in ipairs(beh.events) do if not ev.fault then ev.after = beh.after end end
      operands[child.name] = beh
    end
  end
  -- its templates: each instance type explored once (docs/verify.md, "A fleet"; dca.verify.template)
  local templates = template.explore(node, function(n) return group(ctx, n) end, ctx.faults)
  local list, perrs = group_props(node, ctx.ast)
  for _, e in ipairs(perrs) do ctx.errors[#ctx.errors + 1] = e end
  local sets = set_conflicts(node, ctx.conns)
  for _, p in ipairs(cross_conflicts(node, ctx.conns)) do sets[#sets + 1] = p end
  local r = M.expression(def.actions.expr, operands, list, sets, ctx.max_states, ctx.reduce, ctx.together[def.name])
  local kept = {}
  for _, c in ipairs(r.conflicts) do
    c.inner = c.pair.chain and chain_traces(ctx, c.pair)
    if c.inner or not c.pair.chain then kept[#kept + 1] = c end
  end
  r.conflicts = kept
  r.type, r.path, r.node, r.templates = def.name, node.path, node, templates
  -- an instance escalating the group past its intensity: one more way it ends ABORTED by a fault
  for _, x in ipairs(template.fault_reasons(node.name, r)) do
    r.aborted[#r.aborted + 1] = { reason = x.text, fault = true, trace = {} }
  end
  ctx.states, ctx.transitions = ctx.states + r.states, ctx.transitions + r.transitions
  ctx.memo[def.name] = r
  ctx.groups[#ctx.groups + 1] = r
  return r
end

-- The inputs declared `exclusive INST.PORT` in the verify sections of the tree's groups: { { node, prop } };
-- a port that is no input of INST is an error at its file:line:col (ctx.errors).
local function exclusive_decls(tree, ctx)
  local out, seen = {}, {}
  model.walk(tree, function(node)
    if node.kind ~= "group" then return end
    for _, p in ipairs((props.of_process(node.process, { [node.name] = true }))) do
      local child = p.kind == "one_writer" and node.children[p.a.text]
      if child then
        local port = p.port.text
        local leaf, lport = model.resolve(node, p.a.text, port)
        local ok = leaf ~= nil and not leaf.manifest  -- a type the registry does not know: nor its ports
        for _, q in ipairs(leaf and leaf.manifest and leaf.manifest.inputs or {}) do ok = ok or q.name == lport end
        if ok then out[#out + 1] = { node = node, prop = p }
        elseif not seen[p.pos] then
          seen[p.pos] = true
          local line, col = 0, 0
          if ctx.ast then line, col = ctx.ast.index:at(p.port.pos) end
          ctx.errors[#ctx.errors + 1] = { line = line, col = col, path = node.path,
            msg = sformat("'%s' has no input '%s' (exclusive names an input of an instance)", p.a.text, port) }
        end
      end
    end
  end)
  return out
end

-- Each `exclusive INST.PORT` property becomes a verdict of its group: violated when two writers of that input
-- were found (the finding has the trace), unknown when a partial exploration left a pair undecided.
local function exclusive_verdicts(plan, ctx)
  local seen = {}
  for _, d in ipairs(plan.decls) do
    local r = ctx.memo[d.node.process.name]
    if r and not seen[r.type .. "\0" .. d.prop.pos] then
      seen[r.type .. "\0" .. d.prop.pos] = true
      local shown = d.node.path .. "." .. d.prop.a.text .. "." .. d.prop.port.text
      local item = { prop = d.prop, ok = true }
      for _, g in ipairs(ctx.groups) do
        for _, w in ipairs(g.writers) do
          if w.input == shown and item.ok then item.ok, item.writers = false, w end
        end
        for _, u in ipairs(g.writers_unknown) do
          if item.ok and u:find(" " .. shown .. " ", 1, true) then item.ok, item.unknown = nil, true end
        end
      end
      r.props[#r.props + 1] = item
      sort(r.props, function(x, y) return x.prop.pos < y.prop.pos end)
    end
  end
end

--- Verifies the tree of a checked system (dca.load.file's second result). opts: { faults = true|false,
--- ast = the AST (for property errors' positions), max_states = N per group, actuators = { [world input] = the
--- input whose actuator it drives } (its writers are that input's: dca.verify.writers) }. Returns the result (see the
--- top), or nil and a list of errors { line, col, path, msg } (a property that does not parse).
function M.system(tree, opts)
  opts = opts or {}
  local t0 = clock()
  local conns = model.connections(tree) or {}
  local ctx = { memo = {}, groups = {}, errors = {}, states = 0, transitions = 0, conns = conns,
                faults = opts.faults ~= false, ast = opts.ast, max_states = opts.max_states, reduce = opts.reduce }
  local plan = writers.plan(tree, conns, exclusive_decls(tree, ctx), opts.actuators)
  plan.decls = plan.decls or {}
  ctx.together = writers.needs(plan)
  local root = group(ctx, tree)
  if #ctx.errors > 0 then return nil, ctx.errors end
  local found = writers.findings(plan, ctx.memo)
  for _, r in ipairs(ctx.groups) do
    local f = found[r] or {}
    r.writers, r.dead_paths, r.claims, r.writers_unknown = f.writers or {}, f.dead_paths or {}, f.claims or {}, f.unknown or {}
  end
  exclusive_verdicts(plan, ctx)
  local partial = 0
  for _, r in ipairs(ctx.groups) do if r.truncated then partial = partial + 1 end end
  return { groups = ctx.groups, root = root, states = ctx.states, transitions = ctx.transitions,
           seconds = clock() - t0, faults = ctx.faults, memory_kb = collectgarbage("count"), truncated = partial,
           max_states = opts.max_states or explore.MAX_STATES }
end

return M
