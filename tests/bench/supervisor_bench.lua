-- Supervisor benchmarks (BENCHMARKS.md format): bring-up of the door-opening system's shape and of a
-- generated 1,000-leaf / 100-group tree on 3 hosts, and preemption latency (a leaf's DONE to the last sibling
-- abort acknowledged) for a `#` three supervisor levels down.
--
-- variant *_memory: the supervisor tree in one process on dca.supervisor.memory (every message deep-copied as
-- for the wire, no sockets): the cost of the supervisor's own logic. Baseline: dca.algebra alone driving the
-- same expressions (start, and the preempting event), which any supervisor must pay.
local fake = require "dca.supervisor.memory"
local algebra = require "dca.algebra"
local spec_mod = require "dca.supervisor.spec"

local clock = os.clock
local sformat = string.format
local src = os.getenv("DCA_SOURCE_DIR") or "."

local function stats(samples)
  table.sort(samples)
  local n = #samples
  local function q(p) return samples[math.max(1, math.min(n, math.ceil(p * n)))] end
  return sformat("n=%d p50_us=%.1f p99_us=%.1f p999_us=%.1f max_us=%.1f", n, q(0.5), q(0.99), q(0.999), samples[n])
end

local function result(bench, variant, samples, extra)
  io.stdout:write(sformat("RESULT bench=%s variant=%s %s%s\n", bench, variant, stats(samples), extra or ""))
  io.stdout:flush()
end

-- The bring-up figures of one tree shape (`make` builds its spec) and, as variant too, its baseline's.
local function bringup_results(make, variant, samples, baseline_bench, baseline)
  local g, l, k = spec_mod.count(make())
  result("supervisor_bringup", variant, samples, sformat(" groups=%d leaves=%d connections=%d", g, l, k))
  result(baseline_bench, variant, baseline)
end

-- The door-opening system's configuration defaults (its config("key") parameters), for the in-memory cluster.
local door_config = {}
for _, e in ipairs(assert(require("dca.config").read_file(src .. "/worlds/door/systems/door_open.config"))) do
  door_config[e.key] = e.value
end

-- The door-opening system (worlds/door/systems/door_open.dca) as a spec.
local function door_spec()
  local ast, tree = require("dca.load").file(src .. "/worlds/door/systems/door_open.dca", { registry = false })
  assert(ast and tree, tree)
  return spec_mod.from_model(tree, "door_open.dca")
end

-- A generated tree: 100 groups of 10 leaves on hosts h1..h3, each group chaining its leaves with one set.
local generated = dofile(src .. "/tests/support/generated_tree.lua")

local function all_exprs(spec, f)
  spec_mod.walk(spec, function(n) if n.kind == "group" and n.spec.expr then f(n.spec.expr) end end)
end

local function bringup(name, make, reps)
  local sup_t, base_t = {}, {}
  for _ = 1, reps do
    -- A: the supervisor tree (start, connect, confirm, run)
    local spec = make()
    local t0 = clock()
    local c = fake.cluster{ config = door_config }
    c:root(spec)
    assert(c:configure())
    c:start()
    c:settle(c.t)
    sup_t[#sup_t + 1] = (clock() - t0) * 1e6
    -- B: the algebra alone starting the same expressions
    t0 = clock()
    all_exprs(spec, function(text)
      local run = algebra.new(assert(algebra.parse(text)), {})
      run:start()
    end)
    base_t[#base_t + 1] = (clock() - t0) * 1e6
  end
  bringup_results(make, name .. "_memory", sup_t, "algebra_start_baseline", base_t)
end

-- Preemption: root -> a -> b -> c, c runs `win # (s1, s2, s3)`. From win's DONE to the last abort ack.
local function preemption(reps)
  local function level3()
    local c3 = fake.group("c", "C", "h3", "win # (s1 , s2 , s3)", {
      fake.leaf("win", "Worker", "h3"), fake.leaf("s1", "Worker", "h1"), fake.leaf("s2", "Worker", "h2"),
      fake.leaf("s3", "Worker", "h3") })
    local b = fake.group("b", "B", "h2", "c", { c3 })
    local a = fake.group("a", "A", "h1", "b", { b })
    return fake.root("main", "h1", "a", { a })
  end
  local c = fake.cluster{}
  c:root(level3())
  assert(c:configure())
  local sup_t, base_t = {}, {}
  for _ = 1, reps do
    c:start()
    c:settle(c.t)
    local csup = c.sups["main.a.b.c"]
    local t0 = clock()
    c:node("main.a.b.c.win"):done(1)
    c:settle(c.t, function() return csup.state == "done" and (csup.stops_pending or 0) == 0 end)
    sup_t[#sup_t + 1] = (clock() - t0) * 1e6
    c:settle(c.t, function() return c.outcome ~= nil end)
    -- baseline: the algebra alone taking the same DONE and issuing the three aborts
    local run = algebra.new(assert(algebra.parse("win # (s1 , s2 , s3)")), {})
    run:start()
    t0 = clock()
    run:event("win", "done", 1)
    base_t[#base_t + 1] = (clock() - t0) * 1e6
  end
  result("supervisor_preemption", "3_levels_memory", sup_t)
  result("algebra_preemption_baseline", "3_levels_memory", base_t)
end

for _ = 1, 2 do -- A B A B
  bringup("door_shape_3hosts", door_spec, 50)
  bringup("1000leaves_100groups_3hosts", function() return generated(100, 10, true) end, 3)
  preemption(500)
end

---------------------------------------------------------------------------------------------- real processes
-- variant *_loopback: local daemons, real `dca node` and `dca supervise` processes (dca.scenario.real),
-- measured with the wall clock; *_loopback_group and *_loopback_host with the leaves co-located in shared nodes
-- (`dca run --placement group|host`). Baseline: a ping round trip to a daemon over the same authenticated
-- loopback channel, the least any supervisor-to-process exchange costs.
local core = require "dca.core"
local function has_node()
  local exe = os.getenv("DCA_EXE") or "dca"
  local p = io.popen(exe .. " help 2>&1")
  local out = p:read("a")
  p:close()
  return out:find("\n  node ", 1, true) ~= nil
end
if not (core.loop and core.connect and has_node()) then
  io.stderr:write("supervisor_bench: no control plane or no `dca node` in this build: loopback variants not run\n")
  return 0
end
local real = require "dca.scenario.real"
-- DCA_BENCH_PLACEMENTS="host,group,process" (default: all three) chooses the placements measured.
local PLACEMENTS, PLACEMENTS_BIG = {}, {}
for p in (os.getenv("DCA_BENCH_PLACEMENTS") or "process,group,host"):gmatch("[^,%s]+") do
  PLACEMENTS[#PLACEMENTS + 1] = p
  PLACEMENTS_BIG[p] = true
end
local wall = core.now

-- Every leaf a Gain (In -> Out, periodic, runs until stopped); ports renamed to In/Out.
local function as_gains(spec)
  spec_mod.walk(spec, function(n)
    if n.kind ~= "group" then return end
    local g = n.spec
    local kind = {}
    for _, c in ipairs(g.children) do
      kind[c.name] = c.kind
      if c.kind == "leaf" then c.type, c.args = "Gain", { 1.0, 0.01 } end
    end
    for _, x in ipairs(g.external_io) do
      if kind[x.instance] == "leaf" then x.port = x.alias:match("^In") and "In" or "Out" end
    end
    for _, st in ipairs(g.sets) do
      for _, k in ipairs(st.connections) do
        if kind[k.from] == "leaf" then k.out = "Out" end
        if kind[k.to] == "leaf" then k["in"] = "In" end
      end
    end
  end)
  return spec
end

local function ping_baseline(sys, n)
  local ch = sys:_daemon(sys.daemons.order[1])
  local out = {}
  for _ = 1, n do
    local t0 = wall()
    sys:_ask(function(k) ch:request({ type = "ping" }, 5, k) end, 6, "ping")
    out[#out + 1] = (wall() - t0) * 1e6
  end
  return out
end

-- placement: where the leaves run (`dca run --placement`): "process" (default), "group" or "host"; the variant
-- names it unless it is the default.
local function real_bringup(name, make, reps, placement)
  local up_t, base = {}, nil
  if placement and placement ~= "process" then name = name .. "_" .. placement end
  for _ = 1, reps do
    local sys = real.system(make(), { placement = placement })
    assert(sys:start_hosts()) -- the hosts' daemons run before a system is brought up
    -- the baseline before the system runs: 1,000 running nodes saturate a small machine, and a fresh channel
    -- to a daemon then times out
    base = base or ping_baseline(sys, 200)
    local t0 = wall()
    sys:up(60)
    sys:run()
    up_t[#up_t + 1] = (wall() - t0) * 1e6
    sys:stop()
  end
  bringup_results(make, name .. "_loopback", up_t, "daemon_ping_baseline", base)
end

local function real_preemption(reps)
  local c3 = fake.group("c", "C", "h3", "win # (s1 , s2 , s3)", {
    fake.leaf("win", "Timer", "h3", { 0.02 }), fake.leaf("s1", "Gain", "h1", { 1.0, 0.01 }),
    fake.leaf("s2", "Gain", "h2", { 1.0, 0.01 }), fake.leaf("s3", "Gain", "h3", { 1.0, 0.01 }) })
  local spec = fake.root("main", "h1", "a", { fake.group("a", "A", "h1", "b", {
    fake.group("b", "B", "h2", "c", { c3 }) }) })
  local sys = real.system(spec, {})
  sys:up(30)
  for _ = 1, reps do
    sys:run()
    sys:wait_outcome(10)
  end
  local r = sys:_ask(function(k) sys.sup:handle({ type = "stats", path = "main.a.b.c" }, k) end, 5, "stats")
  local samples = {}
  for _, v in ipairs(r.stats.preempt or {}) do samples[#samples + 1] = v * 1e6 end
  result("supervisor_preemption", "3_levels_loopback", samples)
  result("daemon_ping_baseline", "3_levels_loopback", ping_baseline(sys, 200))
  sys:stop()
end

for _ = 1, 2 do
  for _, placement in ipairs(PLACEMENTS) do
    real_bringup("door_shape_3hosts", function() return as_gains(door_spec()) end, 3, placement)
  end
  real_preemption(100)
end
-- 1,000 node processes at once: only when asked (DCA_BENCH_BIG=1), it needs several GB of memory
if os.getenv("DCA_BENCH_BIG") ~= "1" then
  io.stderr:write("supervisor_bench: 1000leaves_100groups_3hosts_loopback skipped (set DCA_BENCH_BIG=1)\n")
  return 0
end
local function big()
  local s = generated(100, 10, true)
  spec_mod.walk(s, function(n) if n.kind == "leaf" then n.type, n.args = "Gain", { 1.0, 0.01 } end end)
  for _, c in ipairs(s.children) do
    for _, st in ipairs(c.spec.sets) do for _, k in ipairs(st.connections) do k.out, k["in"] = "Out", "In" end end
  end
  return s
end
-- co-location by host first (the target: under 2 s), then by group, then one process per leaf (the baseline
-- of placements: 1,000 spawns), A B A B
for _ = 1, 2 do
  for _, placement in ipairs({ "host", "group", "process" }) do
    if PLACEMENTS_BIG[placement] then real_bringup("1000leaves_100groups_3hosts", big, 1, placement) end
  end
end
