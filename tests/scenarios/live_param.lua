-- Live parameters in a real run on simulated time (docs/configuration.md, "Live parameters"): a Gain whose k is
-- config("test.gain") scales a Constant 1, so its output is its k (scripts/systems/test_live.dca; the mock UR10 is
-- the clock master). With time held, config.set of the key reaches the running Gain: the line at the leaf says so,
-- nothing moves until time flows, and its next tick writes the new k; the run's trace has the change at that tick
-- (tests/scenarios/CMakeLists.txt runs this twice more and compares the traces). A value of the wrong type is
-- refused and said the same way, the Gain keeping its k; the Counter's period is not live: its change is said to
-- apply at the leaf's next start.
local S = require "dca.scenario"
S.backends = { "real" }
local src = os.getenv("DCA_SOURCE_DIR") or "."
local sys = S.system(src .. "/scripts/systems/test_live.dca", { sim = "mock:" .. src .. "/worlds/ur10/ur10.urdf" })

-- The Gain's k as its latest output shows it (k * 1).
local function k_seen()
  local v = sys:read("main.scale", "Out")
  return type(v) == "table" and v[1] or v
end

-- Writes key = value in the repository (as config.set in `dca repl`) and waits for the line matching `pattern`.
local function set_and_see(key, value, pattern)
  local from = #sys:transitions()
  sys:config("h1"):set(key, value)
  sys:wait_line("the line " .. pattern, pattern, 30, from)
end

local at
S.step("the tree comes up on simulated time", function() sys:up(60) end)

S.step("the Gain writes the repository's k = 2 (time held at 0.5 s)", function()
  sys:world_hold_when(0.5)  -- (set before time flows: nothing here slows it, 0.5 s pass in a moment)
  sys:run()
  at = sys:world_wait_held(0.5, 60)
  S.eq(k_seen(), 2)
end)

S.step("config.set while time is held: k = 3 (live) at the Gain, taken from the next tick on", function()
  set_and_see("test.gain", 3, "^main%.scale: k = 3 %(live%)$")
  S.eq(k_seen(), 2, "nothing ran since: time is held")
  S.eq(sys:world_status().t, at)
  at = sys:world_hold_at(at + 0.05, 60)
  S.eq(k_seen(), 3)
  S.eq(sys:state("main.scale"), "running")
end)

S.step("a value of the wrong type is refused and said at the leaf; the Gain keeps k = 3 and runs on", function()
  set_and_see("test.gain", "fast", "^main%.scale: k not changed: parameter 'k' must be a number, got 'fast'$")
  at = sys:world_hold_at(at + 0.05, 60)
  S.eq(k_seen(), 3)
  S.eq(sys:state("main.scale"), "running")
end)

S.step("the Counter's period is not live: said to apply at its next start", function()
  set_and_see("test.period", 0.02, "^main%.ramp: period = 0%.02 in the repository %(config key 'test%.period'%); "
    .. "not live: applies at the leaf's next start %(restart%)$")
end)

S.step("time flows on: the Timer ends the run DONE", function()
  sys:world_go()
  local out = sys:wait_outcome(60)
  S.eq(out.type, "done")
end)

-- The trace's lines of the Gain: "T P main.scale k=3" once, and each D line of its output (every 10 ms): k, 2
-- before the change's tick and 3 from it on.
S.step("the run's trace has the change at its tick, and the Gain's output 2 before it, 3 from it", function()
  S.ok(sys:stop(), "all stopped")
  local file = sys.opts.trace_file
  local changes, outs = {}, {}
  for line in io.lines(file) do
    local t, what = line:match("^(%d+) P main%.scale (.*)$")
    if t then changes[#changes + 1] = { tonumber(t), what } end
    local td, n, v = line:match("^(%d+) D main%.scale%.Out n=(%d+) digest=%S+ value=%[?([-%d.e+]+)")
    if td then outs[#outs + 1] = { t = tonumber(td), n = tonumber(n), v = tonumber(v) } end
  end
  S.eq(#changes, 1, "one change in " .. file)
  local tp = changes[1][1]
  S.eq(changes[1][2], "k=3")
  S.ok(tp > 0.5e9 and tp <= 0.52e9, "the change's tick " .. tp .. " ns: the first after the hold at 0.5 s")
  local before, after = 0, 0
  for _, o in ipairs(outs) do
    S.eq(o.v, o.t < tp and 2 or 3, string.format("sample %d at %d ns", o.n, o.t))
    if o.t < tp then before = before + 1 else after = after + 1 end
  end
  S.ok(before > 10 and after > 10, string.format("%d samples before, %d from the change", before, after))
  S.eq(outs[before + 1].t, tp, "the first sample of k = 3 at the change's tick")
end)

return S.finish()
