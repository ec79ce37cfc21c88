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
--   --   (dca.verify.props), max_states = N }
--
-- Reductions, both sound for this algebra: a state is the set of running leaf occurrences (not their start
-- order, which only orders abort commands) with the values collected so far, so interleavings of independent
-- events meet in one state; and an operand that is a group is only its outcomes (explored once, by the caller).
--
-- The result g:
--   g.done[value] = trace, g.aborted[operand] = { trace =, ev = } (the event that ended the group), g.stuck =
--   { { trace, waiting = { names } } }, g.started[leaf id] = true, g.conflicts = { { pair, trace } },
--   g.first_running[operand or "owner[label]"] = a shortest trace to a state where it runs,
--   g.violations[monitor index] = trace, g.states, g.transitions, g.cycle (a state that can repeat: :;)
--   A trace is a list of steps { name =, ev = } from the start.
local algebra = require "dca.algebra"

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
local function findings(g, ctx, i, snap)
  local c = ctx.c
  local names = running_names(c, snap.running)
  local live = false
  for _, l in ipairs(snap.running) do
    for _, ev in ipairs(ctx.operands[c.name[l]].events) do
      if not ev.fault then live = true end
    end
  end
  if not live and #snap.running > 0 then
    local waiting = {}
    for _, l in ipairs(snap.running) do waiting[#waiting + 1] = c.name[l] end
    local w = concat(waiting, ", ")
    if not g.stuck_seen[w] then  -- the shortest trace to each set of waited-for operands
      g.stuck_seen[w] = true
      g.stuck[#g.stuck + 1] = { trace = trace_to(ctx.states, i), waiting = waiting, state = i }
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
  for k, m in ipairs(ctx.monitors) do
    if m.state and not g.violations[k] and m.state(names) then g.violations[k] = trace_to(ctx.states, i) end
  end
end

-- Timers (a leaf whose type ends `after` a number of seconds, known: operands[name].after): those started in
-- one step form a cohort, and in a cohort the shorter ends first (a longer one's own end waits until no
-- shorter one of its cohort runs). Timers started in different steps may end in any order: the explorer has
-- no clock. --> { [leaf id] = cohort's smallest member }, its text for the state's key (nil, "" without timers)
local function cohorts(ctx, prev, prev_running, running)
  if not ctx.timed_any then return nil, "" end
  local was = {}
  for _, l in ipairs(prev_running or {}) do was[l] = true end
  local groups, order = {}, {}
  for _, l in ipairs(running) do
    if ctx.timed[l] then
      local rep = (prev and was[l] and prev[l]) or "new"
      if not groups[rep] then groups[rep] = {} order[#order + 1] = rep end
      local m = groups[rep]
      m[#m + 1] = l
    end
  end
  local cohort, parts = {}, {}
  for _, rep in ipairs(order) do
    local members = groups[rep]
    sort(members)
    for _, l in ipairs(members) do cohort[l] = members[1] end
    parts[#parts + 1] = concat(members, ",")
  end
  sort(parts)
  return cohort, concat(parts, ";")
end

-- Whether timer l may end by itself now: no shorter timer of its cohort is running.
local function timer_may_end(ctx, cohort, running, l)
  local d = ctx.timed[l]
  if not d or not cohort then return true end
  for _, m in ipairs(running) do
    local dm = ctx.timed[m]
    if m ~= l and dm and dm < d and cohort[m] == cohort[l] then return false end
  end
  return true
end

-- Reaching a snapshot: an end (recorded), a known state (skipped), or a new state (queued).
local function reach(g, ctx, from, step, snap, mstate, cohort, ckey)
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
  local key = key_of(ctx.c, snap, mstate .. "|" .. ckey)
  local known = ctx.seen[key]
  local states = ctx.states
  local i = known or #states + 1
  if from then
    local n = #ctx.efrom + 1
    ctx.efrom[n], ctx.eto[n] = from, i
  end
  if known then return end
  states[i] = { snap = snap, from = from, step = step, mon = mstate, cohort = cohort }
  ctx.seen[key] = i
  for _, l in ipairs(snap.running) do
    g.started[l] = true
    local nm = ctx.c.name[l]
    if not g.first_running[nm] then g.first_running[nm] = trace_to(states, i) end
    local set = ctx.c.label[l] and (nm .. "[" .. ctx.c.label[l] .. "]")
    if set and not g.first_running[set] then g.first_running[set] = trace_to(states, i) end
  end
  findings(g, ctx, i, snap)
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

--- Explores the expression (see the top of the file). Returns g.
function M.group(expr, operands, opts)
  opts = opts or {}
  local rec = recorder()
  local run = algebra.new(expr, rec.commands)
  local ctx = { c = expr.c, operands = operands, sets = opts.sets or {}, monitors = opts.monitors or {},
                seen = {}, states = {}, efrom = {}, eto = {}, timed = {} }
  for id = 1, expr.c.n do
    local op = expr.c.name[id] and operands[expr.c.name[id]]
    if op and op.after then ctx.timed[id], ctx.timed_any = op.after, true end
  end
  local g = { done = {}, aborted = {}, stuck = {}, stuck_seen = {}, started = {}, first_running = {}, conflicts = {}, conflict_seen = {},
              violations = {},
              states = 0, transitions = 0, expr = expr }
  local m0 = {}
  for i, m in ipairs(ctx.monitors) do m0[i] = m.initial or "0" end
  run:start()
  local first = { name = nil, ev = { kind = "start" } }
  local mstate, bad = monitor_step(ctx.monitors, concat(m0), first, rec, nil)
  for _, k in ipairs(bad or {}) do g.violations[k] = g.violations[k] or {} end
  local snap0 = run:snapshot()
  reach(g, ctx, nil, nil, snap0, mstate, cohorts(ctx, nil, nil, snap0.running))
  local max = opts.max_states or 500000
  local monitors_n = #ctx.monitors
  local states, i = ctx.states, 1
  while states[i] do
    local st = states[i]
    local snap = st.snap
    for _, l in ipairs(snap.running) do
      local name = ctx.c.name[l]
      local timer_ok = timer_may_end(ctx, st.cohort, snap.running, l)
      for _, ev in ipairs(operands[name].events) do
        if not (ev.fault or timer_ok) then goto next_event end
        run:restore(snap)
        rec.reset()
        run:event(name, ev.kind, ev.value)
        g.transitions = g.transitions + 1
        local step = { name = name, ev = ev }
        local after = run:snapshot()
        local ms, viol = st.mon, nil
        if monitors_n > 0 then
          ms, viol = monitor_step(ctx.monitors, st.mon, step, rec, running_names(ctx.c, after.running))
        end
        for _, k in ipairs(viol or {}) do
          if not g.violations[k] then g.violations[k] = trace_to(states, i, step) end
        end
        reach(g, ctx, i, step, after, ms, cohorts(ctx, st.cohort, snap.running, after.running))
        ::next_event::
      end
    end
    st.snap = nil  -- expanded: traces need only the links
    i = i + 1
    if i > max and states[i] then g.truncated = true break end
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
