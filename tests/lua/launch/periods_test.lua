-- `dca run --sim`: the control periods of MotionControl in the summary (which leaves, the line the bench
-- reads) and --realtime (the world paced to the wall clock). The figures themselves come from the nodes'
-- `stats` (tests/host/node_test.cpp, timers_test.cpp); tests/bench/motion_period_bench.lua runs the door.
local T = require "dca.testing"
local suite = T.suite("run_periods")

local dca = os.getenv("DCA_EXE") or "dca"
local src = os.getenv("DCA_SOURCE_DIR") or "."

suite:case("the_world_argv_carries_realtime_only_when_asked", function()
  local sim = require "dca.clients.world"
  local argv = sim.argv({ daemon = "127.0.0.1:1", host = "h", world = "door", realtime = true })
  T.eq(argv, { "dca", "sim", "--serve", "--daemon", "127.0.0.1:1", "--host", "h", "--world", "door", "--realtime" })
  for _, a in ipairs(sim.argv({ daemon = "127.0.0.1:1", host = "h" })) do
    T.ok(a ~= "--realtime", "no --realtime unless asked")
  end
end)

suite:case("the_period_leaves_of_the_door_are_motioncontrols_three_controllers", function()
  local run = require "dca.cli.run"
  local sim = require "dca.clients.world"
  local spec, err = run.load(src .. "/scripts/systems/door_open.dca")
  T.ok(spec, tostring(err))
  T.eq(sim.period_leaves(spec), { "main.dooropensyst.motionctrl.xr4000", "main.dooropensyst.motionctrl.puma",
                                  "main.dooropensyst.motionctrl.redundancy" })
  T.eq(sim.period_leaves(spec, "NoSuchGroup"), {})
end)

suite:case("the_period_line_gives_both_clocks_in_ms", function()
  local sim = require "dca.clients.world"
  local line = sim.period_line("main.m.redundancy", {
    name = "main.m.redundancy", period_s = 0.001,
    clock = { n = 999, p50_us = 1000, p99_us = 1000, p999_us = 1000, max_us = 1000 },
    wall = { n = 999, p50_us = 1012.4, p99_us = 1480, p999_us = 2900.4, max_us = 4100 } })
  T.eq(line, "MotionControl period main.m.redundancy: nominal 1.000 ms; sim n 999 p50 1.000 ms p99 1.000 ms "
    .. "max 1.000 ms; wall n 999 p50 1.012 ms p99 1.480 ms p999 2.900 ms max 4.100 ms")
end)

suite:case("run_realtime_needs_sim", function()
  local out, rc = T.sh(dca .. " run " .. src .. "/scripts/systems/door_open.dca --realtime")
  T.eq(rc, 2, "exit code")
  T.contains(out, "--realtime goes with --sim WORLD")
end)

return suite:run(...)
