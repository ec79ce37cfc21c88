-- dca check --verify as a benchmark (BENCHMARKS.md format): the door system (scripts/systems/door_open.dca)
-- fully verified; a generated system of 2,000 leaves in 200 groups (20 groups of 10 groups of 10 leaves, each
-- group its own process definition, random expressions over leaves of the built-in types so that every way of
-- ending occurs); the same 200 groups each one ten-way ','; and one ',' of 12 and of 16 leaves (2^n states
-- without the reduction: the explorer's worst case). Each beside its baselines measured in the same run,
-- alternated A B A B: the same file loaded and checked (dca.load: parse, check, build) without exploring, and
-- the full exploration (opts.reduce = false: every event in every state) where it takes seconds, not minutes
-- (the 16-leaf ',' and the 200 ten-way groups in full only with `full`: about a minute each). Reports states
-- explored, states per second and memory.
--   dca lua tests/bench/verify_bench.lua [rounds] [full]
local load = require "dca.load"
local verify = require "dca.verify"

local ROUNDS, FULL = tonumber((...)) or 2, select(2, ...) == "full"
local src = os.getenv("DCA_SOURCE_DIR") or "."
local gen = dofile(src .. "/tests/support/verify_gen.lua")
local clock = os.clock

-- The built-in leaf types and their arguments after the host: DONE only, ABORTED only, never, DONE later.
local LEAVES = { 'Threshold("h", 1)', 'Deadline("h", 5)', 'Constant("h", 0.1, 1)', 'Timer("h", 3)',
                 'Counter("h", 0.1, 5)', 'Sum("h")' }

-- Leaf types that end DONE by themselves: a ',' of them has 2^n states in full.
local DONE_LEAVES = { 'Threshold("h", 1)', 'Counter("h", 0.1, 5)', 'Timer("h", 3)' }

-- A .dca text: 200 leaf groups G<g> of 10 leaves, 20 middle groups M<m> of 10 of them, main over the 20. With
-- `wide`, every leaf group's expression is one ten-way ',', its leaves of the types that end DONE.
local function generated(wide)
  local seed = 2000
  local function rnd(n) seed = (seed * 1103515245 + 12345) % 2147483648 return seed % n + 1 end
  local out = {}
  local function group(name, kids, types, flat)
    out[#out + 1] = "process " .. name .. "() {\n  instantiated_processes {\n"
    for i, k in ipairs(kids) do out[#out + 1] = string.format("    L%d instof %s;\n", i, types[i]) end
    local text = flat and table.concat(kids, " , ") or gen.tree(rnd, 1, #kids)
    out[#out + 1] = "  }\n  internal_event_actions { " .. text .. " }\n}\n"
  end
  for g = 1, 200 do
    local kids, types = {}, {}
    local pool = wide and DONE_LEAVES or LEAVES
    for i = 1, 10 do kids[i], types[i] = "L" .. i, pool[rnd(#pool)] end
    group("G" .. g, kids, types, wide)
  end
  for m = 1, 20 do
    local kids, types = {}, {}
    for i = 1, 10 do kids[i], types[i] = "L" .. i, "G" .. ((m - 1) * 10 + i) .. "()" end
    group("M" .. m, kids, types)
  end
  local kids, types = {}, {}
  for i = 1, 20 do kids[i], types[i] = "L" .. i, "M" .. i .. "()" end
  group("main", kids, types)
  return table.concat(out)
end

local function result(bench, variant, seconds, extra)
  local us = seconds * 1e6
  io.write(string.format("RESULT bench=%s variant=%s n=1 p50_us=%.0f p99_us=%.0f p999_us=%.0f max_us=%.0f%s\n",
                         bench, variant, us, us, us, us, extra or ""))
  io.flush()
end

-- Loads (the baseline) or loads and verifies the text (reduce = false: in full); returns seconds, result.
local function run(text, name, explore, reduce)
  collectgarbage("collect")
  local t0 = clock()
  local ast, tree = load.text(text, name, {})
  assert(ast, tree)
  local r
  if explore then r = assert(verify.system(tree, { ast = ast, reduce = reduce })) end
  return clock() - t0, r
end

-- The verdicts of a result, as one text (the reduced exploration must print the same as the full one).
local function verdicts(r)
  local out = {}
  for _, g in ipairs(r.groups) do
    local parts = { g.path }
    for _, d in ipairs(g.done) do parts[#parts + 1] = "done " .. d.value end
    for _, a in ipairs(g.aborted) do parts[#parts + 1] = "aborted " .. a.reason end
    for _, st in ipairs(g.stuck) do parts[#parts + 1] = "stuck " .. table.concat(st.waiting, ",") end
    parts[#parts + 1] = "dead " .. #g.dead
    out[#out + 1] = table.concat(parts, "; ")
  end
  table.sort(out)
  return table.concat(out, "\n")
end

local function verify_once(text, name, variant, base, reduce)
  collectgarbage("collect")
  local kb0 = collectgarbage("count")
  local t, r = run(text, name, true, reduce)
  local kb = collectgarbage("count") - kb0
  local leaves = 0
  for _, g in ipairs(r.groups) do leaves = leaves + #g.expr.leaves end
  local explore = math.max(t - base, 1e-6)  -- the exploration's share: verify minus the load it includes
  result(reduce == false and "dca_check_verify_full" or "dca_check_verify", variant, t, string.format(
    " states=%d transitions=%d explore_us=%.0f states_per_s=%.0f transitions_per_s=%.0f groups=%d " ..
    "leaf_occurrences=%d memory_kb=%.0f", r.states, r.transitions, explore * 1e6, r.states / explore,
    r.transitions / explore, #r.groups, leaves, kb))
  return r
end

-- The load baseline, the reduced exploration and (with `full`) the full one, whose verdicts must agree.
local function bench(text, name, variant, full)
  local base = run(text, name, false)
  result("dca_check_load", variant, base)
  local r = verify_once(text, name, variant, base, true)
  if full then
    local f = verify_once(text, name, variant, base, false)
    if verdicts(f) ~= verdicts(r) then error("verify_bench: " .. variant .. ": the reduction changed a verdict") end
  end
end

-- The worst case for the explorer: one ',' of n leaves that each end DONE or ABORTED (2^n states, no reduction
-- applies: every subset of them may have ended).
local function concurrent(n)
  local inst, names = {}, {}
  for i = 1, n do
    inst[i] = string.format("    L%d instof %s;\n", i, i % 2 == 0 and 'Threshold("h", 1)' or 'Counter("h", 0.1, 5)')
    names[i] = "L" .. i
  end
  return "process main() {\n  instantiated_processes {\n" .. table.concat(inst) .. "  }\n" ..
         "  internal_event_actions { " .. table.concat(names, " , ") .. " }\n}\n"
end

local door = io.open(src .. "/scripts/systems/door_open.dca"):read("a")
local big, wide = generated(false), generated(true)
io.stderr:write(string.format("verify_bench: door_open.dca and generated systems (%d, %d chars), %d rounds%s\n",
                              #big, #wide, ROUNDS, FULL and ", with the full explorations" or ""))
for _ = 1, ROUNDS do
  bench(door, src .. "/scripts/systems/door_open.dca", "door", true)
  bench(big, "generated_2000_leaves.dca", "generated_2000_leaves", true)
  bench(wide, "wide_200x10_leaves.dca", "wide_200_groups_of_10", FULL)
  bench(concurrent(12), "concurrent_12.dca", "concurrent_12_leaves", true)
  bench(concurrent(16), "concurrent_16.dca", "concurrent_16_leaves", FULL)
end
