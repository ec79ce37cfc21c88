-- The reduction of dca.verify.explore against the full exploration: on a few hundred generated systems (leaves
-- of every manifest's `ends`, timers, group operands with several DONE values and a way to get stuck, the
-- property patterns, connection-set pairs), with and without faults, both must reach the same verdicts: the
-- ends, the stuck states, the operands that never start, the cycles, what runs at some point and the
-- properties. And the reduction must pay: a ',' of 16 leaves in a few dozen states.
local T = require "dca.testing"
local algebra = require "dca.algebra"
local verify = require "dca.verify"
local props = require "dca.verify.props"
local suite = T.suite("reduce")

local gen = dofile(T.src .. "/tests/support/verify_gen.lua")

-- What a group operand `name` can do: two DONE values, an ABORTED, getting stuck, and a fault.
local function group_operand(name, faults, rnd)
  local ev = { { kind = "done", value = name .. "(x)", group = true } }
  if rnd(2) == 1 then ev[#ev + 1] = { kind = "done", value = name .. "(y)", group = true } end
  if rnd(2) == 1 then
    ev[#ev + 1] = { kind = "aborted", value = name .. " aborted", group = true,
                    reasons = { { text = name .. ".a aborted" } } }
  end
  if rnd(2) == 1 then ev[#ev + 1] = { kind = "stuck", value = "stuck", waiting = { "s" }, inner = {}, group = true } end
  if faults then
    ev[#ev + 1] = { kind = "error", value = "lost", fault = true, group = true,
                    reasons = { { text = name .. " lost", fault = true, lost = true } } }
  end
  return { events = ev }
end

-- The operands of a generated expression: leaves as their `ends` say, some of them timers, some groups.
local function operands(expr, ends, faults, rnd)
  local ops = {}
  for _, name in ipairs(expr.names) do
    local pick = rnd(6)  -- 1: a group; 2, 3: a timer of 1 to 3 s
    if pick == 1 then
      ops[name] = group_operand(name, faults, rnd)
    else
      ops[name] = verify.leaf_events(name, ends[name], faults)
      if pick <= 3 and ends[name] ~= "never" then ops[name].after = rnd(3) end
    end
  end
  return ops
end

-- Everything the two explorations must agree on, as sorted text lines.
local function verdicts(r)
  local out = {}
  for _, d in ipairs(r.done) do out[#out + 1] = "done " .. d.value end
  for _, k in ipairs(r.ends_by) do out[#out + 1] = "end " .. k end
  for _, a in ipairs(r.aborted) do out[#out + 1] = "aborted " .. a.reason end
  for _, s in ipairs(r.stuck) do out[#out + 1] = "stuck " .. table.concat(s.waiting, ", ") end
  for _, l in ipairs(r.dead) do out[#out + 1] = "dead " .. l.id end
  for name in pairs(r.first_running) do out[#out + 1] = "runs " .. name end
  for _, c in ipairs(r.conflicts) do out[#out + 1] = "conflict " .. c.a .. " " .. c.b end
  for _, p in ipairs(r.props) do out[#out + 1] = "prop " .. p.prop.text .. " " .. tostring(p.ok) end
  out[#out + 1] = "cycle " .. tostring(r.cycle) .. " until_stopped " .. tostring(r.until_stopped)
  out[#out + 1] = "never_ends " .. tostring(r.never_ends)
  table.sort(out)
  return out
end

-- Connection-set pairs over random leaves (an operand's name: active while it runs).
local function sets(expr, rnd)
  local out = {}
  for _ = 1, rnd(3) - 1 do
    local a, b = expr.names[rnd(#expr.names)], expr.names[rnd(#expr.names)]
    out[#out + 1] = { a = a, b = b, why = a .. " and " .. b }
  end
  return out
end

-- Leaves that mostly end by themselves (the generator's own mix ends most runs at once).
local ENDS = { "done", "done", "done", "done or aborted", "done or aborted", "never", "aborted", false }

-- (the first 300 systems are the spin cross-check's expressions, tests/lua/verify/promela_test.lua; the others
-- larger, their leaves mostly ending DONE)
suite:case("the_reduced_exploration_reaches_the_full_ones_verdicts_on_700_generated_systems", function()
  local count = T.sanitized and 150 or 700
  local seed, seed2 = 17, 33
  local function rnd(n) seed = (seed * 1103515245 + 12345) % 2147483648 return seed % n + 1 end
  local function rnd2(n) seed2 = (seed2 * 1103515245 + 12345) % 2147483648 return seed2 % n + 1 end
  local reduced_states, full_states, bad = 0, 0, {}
  for i = 1, count do
    local text, ends, ptext = gen.expression(rnd, i <= 300 and 2 + rnd(6) or 2 + rnd(12))
    local expr = assert(algebra.parse(text))
    if i > 300 then for _, name in ipairs(expr.names) do ends[name] = ENDS[rnd2(#ENDS)] or nil end end
    local list = props.parse(ptext, 1)
    local faults = rnd2(2) == 1
    local ops = operands(expr, ends, faults, i <= 300 and function() return 6 end or rnd2)
    -- (timers: a third of the leaves, some in one cohort with different seconds)
    local pairs_ = i > 300 and rnd2(4) == 1 and sets(expr, rnd2) or nil
    local full = verify.expression(expr, ops, list, pairs_, nil, false)
    local red = verify.expression(expr, ops, list, pairs_, nil, true)
    local a, b = verdicts(full), verdicts(red)
    if T.show(a) ~= T.show(b) then bad[#bad + 1] = { i = i, text = text, props = ptext, full = a, reduced = b } end
    full_states, reduced_states = full_states + full.states, reduced_states + red.states
  end
  T.eq(bad, {}, "systems where the reduction changes a verdict")
  io.stderr:write(string.format("reduce: %d systems, %d states full, %d reduced\n", count, full_states,
                                reduced_states))
  T.ok(reduced_states < full_states, "the reduction explores fewer states")
end)

suite:case("writers_running_together_are_found_alike_reduced_or_not_on_300_generated_systems", function()
  -- dca.verify.writers asks each group for a state where some names all run (two writers, their sets'
  -- owners): those names are visible to the reduction, so the reduced exploration must find the same ones
  local seed = 91
  local function rnd(n) seed = (seed * 1103515245 + 12345) % 2147483648 return seed % n + 1 end
  local bad, found = {}, 0
  for i = 1, T.sanitized and 60 or 300 do
    local text, ends = gen.expression(rnd, 3 + rnd(9))
    local expr = assert(algebra.parse(text))
    for _, name in ipairs(expr.names) do ends[name] = ENDS[rnd(#ENDS)] or nil end
    local ops = operands(expr, ends, rnd(2) == 1, rnd)
    local together = {}
    for k = 1, 1 + rnd(3) do
      local names = {}
      for j = 1, 1 + rnd(2) do names[j] = expr.names[rnd(#expr.names)] end
      together[k] = { key = "q" .. k, names = names }
    end
    local full = verify.expression(expr, ops, {}, nil, nil, false, together)
    local red = verify.expression(expr, ops, {}, nil, nil, true, together)
    for _, q in ipairs(together) do
      if (full.together[q.key] == nil) ~= (red.together[q.key] == nil) then
        bad[#bad + 1] = { i = i, text = text, names = q.names }
      elseif full.together[q.key] then found = found + 1 end
    end
  end
  T.eq(bad, {}, "systems where the reduction changes whether writers run together")
  T.ok(found > 0, "some run together")
end)

suite:case("a_concurrent_group_of_16_leaves_takes_a_few_dozen_states", function()
  local names = {}
  for i = 1, 16 do names[i] = "L" .. i end
  local expr = assert(algebra.parse(table.concat(names, " , ")))
  local ops = {}
  for _, name in ipairs(names) do ops[name] = verify.leaf_events(name, "done", true) end
  local r = verify.expression(expr, ops, {}, nil, nil, true)
  T.eq(r.states, 16)  -- the last DONE ends the group: not a state
  T.eq(#r.done, 1)
  T.eq(#r.aborted, 16)
  -- and 12 leaves explored in full: 2^12 states, the same verdicts
  local twelve = assert(algebra.parse(table.concat(names, " , ", 1, 12)))
  local full = verify.expression(twelve, ops, {}, nil, nil, false)
  local red = verify.expression(twelve, ops, {}, nil, nil, true)
  T.eq(full.states, 4095)  -- every subset of the 12 ended but all of them
  T.eq(verdicts(red), verdicts(full))
end)

suite:case("a_timer_that_waits_for_a_shorter_one_still_ends_in_the_reduced_exploration", function()
  -- L3 (1 s) and the Deadline L4 (2 s) start together: L4 can abort only after L3's DONE, which must come
  -- while L2 still runs (else it ends the '#'); picking L2's DONE first would lose "L4 aborted"
  local expr = assert(algebra.parse("(L2 , L3) # L4"))
  local ops = { L2 = verify.leaf_events("L2", "done", false), L3 = verify.leaf_events("L3", "done", false),
                L4 = verify.leaf_events("L4", "aborted", false) }
  ops.L3.after, ops.L4.after = 1, 2
  local full = verify.expression(expr, ops, {}, nil, nil, false)
  local red = verify.expression(expr, ops, {}, nil, nil, true)
  T.eq(full.ends_by, { "aborted:L4" })
  T.eq(verdicts(red), verdicts(full))
end)

return suite:run(...)
