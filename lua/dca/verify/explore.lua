-- dca.verify.explore: every reachable state of one group's expression, explored with dca.algebra itself (the
-- engine the supervisor runs), breadth first, so the first trace found to anything is a shortest one.
--
--   local explore = require "dca.verify.explore"
--   local g = explore.group(expr, operands, opts)
--   -- expr: a dca.algebra expression; operands[name] = { events = { ev, ... } }: what each operand (a leaf's
--   --   type, or a sub-group's outcomes) can do while it runs; ev = { kind = "done"|"aborted"|"error",
--   --   value = <done value>, fault = true|nil, reasons = { ... } (aborted/error) }
--   -- opts: { sets = { { a = "owner[label]", b = "owner[label]" | "operand", why = ... } ... } (connection sets
--   --   that must not be active together; an operand's name: while it runs), monitors = { m ... }
--   --   (dca.verify.props), max_states = N, together = { { key, names = { operand | "owner[label]" } } } }
--
-- Reductions, both sound for this algebra: a state is the set of running leaf occurrences (not their start
-- order, which only orders abort commands) with the values collected so far, so interleavings of independent
-- events meet in one state; and an operand that is a group is only its outcomes (explored once, by the caller).
--
-- The result g:
--   g.done[value] = trace, g.aborted[operand] = { trace =, ev = } (the event that ended the group), g.stuck =
--   { { trace, waiting = { names } } }, g.started[leaf id] = true, g.conflicts = { { pair, trace } },
--   g.first_running[operand or "owner[label]"] = a shortest trace to a state where it runs,
--   g.together[key] = a shortest trace to a state where all of opts.together's { key, names } are active,
--   g.violations[monitor index] = trace, g.states, g.transitions, g.cycle (a state that can repeat: :;)
--   A trace is a list of steps { name =, ev = } from the start.
local algebra = require "dca.algebra"
local zone = require "dca.verify.zone"

local M = {}

local ipairs, pairs, type, tostring, concat, sort, sformat = ipairs, pairs, type, tostring, table.concat, table.sort,
  string.format

-- The text of a value (what a DONE carries: an operand's name, or a ',' list of them).
local function value_text(v)
  if type(v) ~= "table" then return tostring(v) end
  local parts = {}
  for i = 1, v.n or #v do parts[i] = v[i] == nil and "nil" or value_text(v[i]) end
  return "{" .. concat(parts, ", ") .. "}"
end
M.value_text = value_text

-- The key of a snapshot: running occurrences as a set, the values so far of the live ',' nodes (those with a
-- running leaf below them: an aborted ',' leaves its values behind, unused), the monitors' state.
local function key_of(c, s, mon)
  local ids = {}
  for i, l in ipairs(s.running) do ids[i] = l end
  sort(ids)
  local parts = { concat(ids, " ") }
  local vids = {}
  for id in pairs(s.vals) do vids[#vids + 1] = id end
  sort(vids)
  local last = c.last
  for _, id in ipairs(vids) do
    for _, l in ipairs(ids) do
      if l > id and l <= last[id] then
        parts[#parts + 1] = id .. "=" .. value_text(s.vals[id])
        break
      end
    end
  end
  parts[#parts + 1] = mon
  return concat(parts, "|")
end

-- Which connection-set names ("owner[label]") a snapshot has active: its running labelled occurrences; and
-- its running operands' names (a set of a group operand is active only while the group runs).
local function active_sets(c, running)
  local out = {}
  for _, l in ipairs(running) do
    local lb = c.label[l]
    out[c.name[l]] = true
    if lb then out[c.name[l] .. "[" .. lb .. "]"] = true end
  end
  return out
end

-- The trace from the start to state i (steps { name, ev }).
local function trace_to(states, i, last)
  local rev = {}
  if last then rev[1] = last end
  while i and states[i].from do
    rev[#rev + 1] = states[i].step
    i = states[i].from
  end
  local out = {}
  for k = #rev, 1, -1 do out[#out + 1] = rev[k] end
  return out
end
M.trace_to = trace_to

-- The commands one step caused, recorded by the run's command callbacks.
-- (rec.cmds: { "start" | "abort", name } in order).
local function recorder()
  local rec = { cmds = {} }
  rec.commands = {
    start = function(name) rec.cmds[#rec.cmds + 1] = { "start", name } end,
    abort = function(name) rec.cmds[#rec.cmds + 1] = { "abort", name } end,
  }
  function rec.reset() rec.cmds = {} end
  return rec
end
M.recorder = recorder

-- What the monitors do with one step: the next monitor state, and the indices of those it violates (or nil).
local function monitor_step(monitors, mstate, step, rec, running_names)
  if #monitors == 0 then return mstate, nil end
  local next, bad = {}, nil
  for i, m in ipairs(monitors) do
    local st, viol = mstate:sub(i, i), false
    if m.step then st, viol = m.step(st, step, rec, running_names) end
    next[i] = st
    if viol then
      bad = bad or {}
      bad[#bad + 1] = i
    end
  end
  return concat(next), bad
end

local function running_names(c, running)
  local out = {}
  for _, l in ipairs(running) do out[c.name[l]] = true end
  return out
end

-- Records the findings of a state just reached: stuck, conflicting sets, monitors on states.
-- (a group operand that got stuck waits for ever: its `inside` = what it waits on, from its own exploration)
local function findings(g, ctx, i, snap, stuck)
  local c = ctx.c
  local names = running_names(c, snap.running)
  local live = false
  for _, l in ipairs(snap.running) do
    if not (stuck and stuck[l]) then
      for _, ev in ipairs(ctx.operands[c.name[l]].events) do
        if not ev.fault then live = true end
      end
    end
  end
  if not live and #snap.running > 0 then
    local waiting, inside = {}, {}
    for _, l in ipairs(snap.running) do
      local nm = c.name[l]
      waiting[#waiting + 1] = nm
      if stuck and stuck[l] then inside[nm] = ctx.stuck_ev[nm] end
    end
    local w = concat(waiting, ", ")
    if not g.stuck_seen[w] then  -- the shortest trace to each set of waited-for operands
      g.stuck_seen[w] = true
      g.stuck[#g.stuck + 1] = { trace = trace_to(ctx.states, i), waiting = waiting, state = i, inside = inside }
    end
  end
  if ctx.sets[1] then
    local act = active_sets(c, snap.running)
    for _, p in ipairs(ctx.sets) do
      if act[p.a] and act[p.b] and not g.conflict_seen[p] then
        g.conflict_seen[p] = true
        g.conflicts[#g.conflicts + 1] = { pair = p, trace = trace_to(ctx.states, i) }
      end
    end
  end
  if ctx.together[1] then  -- names wanted active together (dca.verify.writers): the first state with all
    local act = active_sets(c, snap.running)
    for _, t in ipairs(ctx.together) do
      if not g.together[t.key] then
        local all = true
        for _, n in ipairs(t.names) do all = all and act[n] == true end
        if all then g.together[t.key] = trace_to(ctx.states, i) end
      end
    end
  end
  for k, m in ipairs(ctx.monitors) do
    if m.state and not g.violations[k] and m.state(names) then g.violations[k] = trace_to(ctx.states, i) end
  end
end

-- Timers (a leaf whose type ends `after` a number of seconds, known: operands[name].after): the zone of their
-- clocks (dca.verify.zone) after the step from prev_running to running by leaf l's event ev. --> the zone,
-- its text for the state's key (nil, "" without timers)
local function timer_zone(ctx, prev, prev_running, running, l, ev)
  if not ctx.timed_any then return nil, "" end
  local own = l ~= nil and ctx.timed[l] ~= nil and not ev.fault and ev.kind ~= "stuck"
  local z = zone.step(prev, ctx.timed, l, own, prev_running or {}, running)
  return z, zone.key(z)
end

-- Whether timer l may end by itself now: its clock can reach its seconds before another timer must end.
local function timer_may_end(ctx, tz, _, l)
  if not ctx.timed[l] or not tz then return true end
  return zone.may_end(tz, ctx.timed, l)
end

-- The key's part for the group occurrences that got stuck (ids, sorted), "" for none.
local function stuck_key(stuck)
  if not stuck then return "" end
  local ids = {}
  for id in pairs(stuck) do ids[#ids + 1] = id end
  sort(ids)
  return concat(ids, ",")
end

-- Reaching a snapshot: an end (recorded), a known state (skipped), or a new state (queued).
local function reach(g, ctx, from, step, snap, mstate, tz, ckey, stuck)
  if snap.st == "done" then
    local v = value_text(snap.value)
    if not g.done[v] then g.done[v] = trace_to(ctx.states, from, step) end
    return
  elseif snap.st == "aborted" then
    local a = g.aborted[step.name .. "\0" .. step.ev.kind .. "\0" .. tostring(step.ev.value)]
    if not a then
      g.aborted[step.name .. "\0" .. step.ev.kind .. "\0" .. tostring(step.ev.value)] =
        { trace = trace_to(ctx.states, from, step), name = step.name, ev = step.ev }
    end
    return
  end
  local key = key_of(ctx.c, snap, mstate .. "|" .. ckey .. "|" .. stuck_key(stuck))
  local known = ctx.seen[key]
  local states = ctx.states
  local i = known or #states + 1
  if from then
    local n = #ctx.efrom + 1
    ctx.efrom[n], ctx.eto[n] = from, i
  end
  if known then return end
  states[i] = { snap = snap, from = from, step = step, mon = mstate, tz = tz, stuck = stuck }
  ctx.seen[key] = i
  for _, l in ipairs(snap.running) do
    g.started[l] = true
    local nm = ctx.c.name[l]
    if not g.first_running[nm] then g.first_running[nm] = trace_to(states, i) end
    local set = ctx.c.label[l] and (nm .. "[" .. ctx.c.label[l] .. "]")
    if set and not g.first_running[set] then g.first_running[set] = trace_to(states, i) end
  end
  findings(g, ctx, i, snap, stuck)
end

-- Whether the state graph has a cycle (Kahn: the states left once those without predecessors are peeled).
local function has_cycle(n, efrom, eto)
  local indeg, out = {}, {}
  for i = 1, n do indeg[i], out[i] = 0, {} end
  for k = 1, #efrom do
    indeg[eto[k]] = indeg[eto[k]] + 1
    local o = out[efrom[k]]
    o[#o + 1] = eto[k]
  end
  local queue, removed = {}, 0
  for i = 1, n do if indeg[i] == 0 then queue[#queue + 1] = i end end
  local h = 1
  while queue[h] do
    local v = queue[h]
    h, removed = h + 1, removed + 1
    for _, w in ipairs(out[v]) do
      indeg[w] = indeg[w] - 1
      if indeg[w] == 0 then queue[#queue + 1] = w end
    end
  end
  return removed < n
end

local PAR, SEQ, DIS, COND, REC = 1, 2, 3, 4, 5  -- dca.algebra's operator codes (expr.c.op)

--- The states explored per group when opts.max_states is not given.
M.MAX_STATES = 500000

-- One event `ev` of leaf occurrence l in state st, not yet reached: { snap, step, ms, viol, tz, ckey,
-- stuck, cmds }. A group operand's "stuck" event changes nothing in the engine: the occurrence still runs,
-- and from now on it can only end by a fault (st.stuck marks it).
local function fire(g, ctx, st, l, ev)
  local run, rec, c = ctx.run, ctx.rec, ctx.c
  local name = c.name[l]
  local step = { name = name, ev = ev }
  rec.reset()
  local after, stuck
  if ev.kind == "stuck" then
    after, stuck = st.snap, { [l] = true }
    for id in pairs(st.stuck or {}) do stuck[id] = true end
  else
    run:restore(st.snap)
    run:event(name, ev.kind, ev.value)
    after = run:snapshot()
    if st.stuck then
      local on = {}
      for _, id in ipairs(after.running) do if st.stuck[id] then on[id] = true stuck = on end end
    end
  end
  g.transitions = g.transitions + 1
  local ms, viol = st.mon, nil
  if ctx.monitors_n > 0 and ev.kind ~= "stuck" then
    ms, viol = monitor_step(ctx.monitors, st.mon, step, rec, running_names(c, after.running))
  end
  local tz, ckey = timer_zone(ctx, st.tz, st.snap.running, after.running, l, ev)
  return { snap = after, step = step, ms = ms, viol = viol, tz = tz, ckey = ckey, stuck = stuck,
           cmds = rec.cmds }
end

local function commit(g, ctx, i, s)
  for _, k in ipairs(s.viol or {}) do
    if not g.violations[k] then g.violations[k] = trace_to(ctx.states, i, s.step) end
  end
  reach(g, ctx, i, s.step, s.snap, s.ms, s.tz, s.ckey, s.stuck)
end

-- Walks up from leaf l: f(p, x) for each ancestor p (x its child on the way) until f says true or false;
-- nil past the root.
local function up(c, l, f)
  local x, p = l, c.parent[l]
  while p ~= 0 do
    local v = f(p, x)
    if v ~= nil then return v end
    x, p = p, c.parent[p]
  end
  return nil
end

-- Whether a DONE of leaf l in snapshot snap stays local: it ends no operand of a '#' (which would abort the
-- others), so it only starts what follows it and counts down a ',' that still waits for another operand.
local function local_done(c, snap, l)
  return up(c, l, function(p, x)
    local o = c.op[p]
    if o == DIS then return false end
    if (o == PAR and snap.cnt[p] > 1) or (o == SEQ and c.cidx[x] < c.nk[p]) or (o == COND and c.cidx[x] == 1)
       or o == REC then
      return true
    end
  end) ~= false
end

-- Whether event ev of leaf l can happen in state st: a stuck group only by a fault; a timer by a fault, or
-- by itself once its clock can reach its seconds (dca.verify.zone).
local function enabled(ctx, st, l, ev, timer_ok)
  if st.stuck and st.stuck[l] then return ev.fault end
  return ev.fault or timer_ok
end

-- The reduction (docs/verify.md "Reduction"): the successors by the moving events (DONE, a group getting
-- stuck) of one leaf whose moves are local and invisible, or nil when no leaf qualifies (all are explored).
-- (A quiet leaf is no timer and starts or aborts none: its DONE leaves the timers' clocks as they are.)
local function ample(g, ctx, st)
  local c, snap = ctx.c, st.snap
  for _, l in ipairs(snap.running) do
    local name = c.name[l]
    if ctx.quiet[l] and not (st.stuck and st.stuck[l]) and local_done(c, snap, l)
       and timer_may_end(ctx, st.tz, snap.running, l) then
      local out = {}
      for _, ev in ipairs(ctx.operands[name].events) do
        if ev.kind == "done" or ev.kind == "stuck" then out[#out + 1] = fire(g, ctx, st, l, ev) end
      end
      if out[1] then return out end
    end
  end
  return nil
end

-- Expands state i: every terminal event (an ABORTED or a fault ends the whole expression: SEMANTICS.md §5)
-- of every running leaf, and the moving events of all of them or of the reduction's one leaf.
local function expand(g, ctx, i)
  local st = ctx.states[i]
  local snap = st.snap
  local amp = ctx.reduce and ample(g, ctx, st)
  for _, l in ipairs(snap.running) do
    local timer_ok = timer_may_end(ctx, st.tz, snap.running, l)
    for _, ev in ipairs(ctx.operands[ctx.c.name[l]].events) do
      local moving = ev.kind == "done" or ev.kind == "stuck"
      if enabled(ctx, st, l, ev, timer_ok) and not (amp and moving) then commit(g, ctx, i, fire(g, ctx, st, l, ev)) end
    end
  end
  for _, s in ipairs(amp or {}) do commit(g, ctx, i, s) end
end

-- Whether a DONE of leaf l can, in any state, start or abort a watched leaf (vis_under[id]: a watched leaf
-- lies below node id): the operand it starts next, the operands a '#' it ends aborts, and so on upward.
local function touches(c, l, vis_under)
  return up(c, l, function(p, x)
    local o, i, ks = c.op[p], c.cidx[x], c.kids[p]
    if o == SEQ and i < c.nk[p] then return vis_under[ks[i + 1]] end
    if o == COND and i == 1 then return vis_under[ks[2]] end
    if o == REC then return vis_under[ks[3 - i]] end
    if o == DIS then
      for j, k in ipairs(ks) do if j ~= i and vis_under[k] then return true end end
    end
  end) or false
end

-- Which leaves the reduction may pick (ctx.quiet[id]): not watched by a monitor or a connection-set pair and
-- no timer (a timer's clock sees when the others start and end), never starting or aborting such a one, and
-- not under a ':;' (its events can repeat: always explored, so that no cycle is left unexplored). A DONE of a quiet leaf changes nothing a property sees, in any state.
local function watched(ctx, expr, opts)
  local visible, c = {}, ctx.c
  for _, m in ipairs(ctx.monitors) do
    if m.all then return nil end
    for _, n in ipairs(m.names or {}) do visible[n] = true end
  end
  for _, p in ipairs(ctx.sets) do
    visible[p.a:match("^[^%[]+")], visible[p.b:match("^[^%[]+")] = true, true
  end
  for _, n in ipairs(opts.visible or {}) do visible[n] = true end
  for _, t in ipairs(ctx.together) do  -- the writers' leaves and sets' owners: their order is seen
    for _, n in ipairs(t.names) do visible[n:match("^[^%[]+")] = true end
  end
  local vis_under, quiet = {}, {}
  for id = c.n, 1, -1 do  -- preorder ids: a node's subtree is id .. c.last[id]
    local v = c.name[id] and (visible[c.name[id]] or ctx.timed[id] ~= nil) or false
    for _, k in ipairs(c.kids[id] or {}) do v = v or vis_under[k] end
    vis_under[id] = v
  end
  for id = 1, c.n do
    if c.name[id] then
      local p = c.parent[id]
      while p ~= 0 and c.op[p] ~= REC do p = c.parent[p] end
      quiet[id] = p == 0 and not vis_under[id] and not touches(c, id, vis_under)
    end
  end
  ctx.quiet = quiet
  return expr
end

--- Explores the expression (see the top of the file). Returns g. opts.reduce = false: every event in every
--- state (the full exploration the reduction is checked against).
function M.group(expr, operands, opts)
  opts = opts or {}
  local rec = recorder()
  local run = algebra.new(expr, rec.commands)
  local ctx = { c = expr.c, operands = operands, sets = opts.sets or {}, monitors = opts.monitors or {},
                seen = {}, states = {}, efrom = {}, eto = {}, timed = {}, run = run, rec = rec, stuck_ev = {},
                together = opts.together or {} }
  ctx.monitors_n = #ctx.monitors
  for id = 1, expr.c.n do
    local op = expr.c.name[id] and operands[expr.c.name[id]]
    if op and op.after then ctx.timed[id], ctx.timed_any = op.after, true end
  end
  ctx.reduce = opts.reduce ~= false and watched(ctx, expr, opts) ~= nil
  for name, op in pairs(operands) do
    for _, ev in ipairs(op.events) do if ev.kind == "stuck" then ctx.stuck_ev[name] = ev end end
  end
  local g = { done = {}, aborted = {}, stuck = {}, stuck_seen = {}, started = {}, first_running = {}, conflicts = {},
              conflict_seen = {}, violations = {}, together = {}, states = 0, transitions = 0, expr = expr, reduced = ctx.reduce }
  local m0 = {}
  for i, m in ipairs(ctx.monitors) do m0[i] = m.initial or "0" end
  run:start()
  local first = { name = nil, ev = { kind = "start" } }
  local mstate, bad = monitor_step(ctx.monitors, concat(m0), first, rec, nil)
  for _, k in ipairs(bad or {}) do g.violations[k] = g.violations[k] or {} end
  local snap0 = run:snapshot()
  reach(g, ctx, nil, nil, snap0, mstate, timer_zone(ctx, nil, nil, snap0.running))
  local max = opts.max_states or M.MAX_STATES
  local states, i = ctx.states, 1
  while states[i] do
    expand(g, ctx, i)
    states[i].snap = nil  -- expanded: traces need only the links
    i = i + 1
    if i > max and states[i] then g.truncated, g.unexplored = true, #states - i + 1 break end
  end
  g.states = #states
  g.state_list = states
  g.cycle = has_cycle(#states, ctx.efrom, ctx.eto)
  return g
end

--- The step names of a trace as text ("a done", "b crashed"), for messages and tests.
function M.trace_text(trace)
  local out = {}
  for i, s in ipairs(trace) do
    local ev = s.ev
    local what = ev.kind == "done" and "done" or (ev.fault and "crashed") or "aborted"
    out[i] = sformat("%s %s", s.name, what)
  end
  return concat(out, "; ")
end

return M
