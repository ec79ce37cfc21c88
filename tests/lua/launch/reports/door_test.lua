-- The door world's report (dca.launch.reports.door) in `dca run --sim`: the control periods of MotionControl
-- in the summary (which leaves, the line the bench reads). The figures themselves come from the nodes'
-- `stats` (tests/host/node_test.cpp, timers_test.cpp); tests/bench/motion_period_bench.lua runs the door.
local T = require "dca.testing"
local suite = T.suite("door")

local src = T.src

suite:case("the_period_leaves_of_the_door_are_motioncontrols_three_controllers", function()
  local door = require "dca.launch.reports.door"
  local spec, err = require("dca.load").spec(src .. "/scripts/systems/door_open.dca")
  T.ok(spec, tostring(err))
  T.eq(door.leaves(spec), { "main.dooropensyst.motionctrl.xr4000", "main.dooropensyst.motionctrl.puma",
                            "main.dooropensyst.motionctrl.redundancy" })
  T.eq(door.leaves(spec, "NoSuchGroup"), {})
end)

suite:case("the_door_world_selects_the_door_report_and_others_none", function()
  local reports = require "dca.launch.reports"
  T.eq(reports.for_world("door"), require("dca.launch.reports.door"))
  T.eq(reports.for_world("nosuchworld").head({ door_angle = 1 }), {})
end)

suite:case("the_period_line_gives_both_clocks_in_ms", function()
  local door = require "dca.launch.reports.door"
  local line = door.period_line("main.m.redundancy", {
    name = "main.m.redundancy", period_s = 0.001,
    clock = { n = 999, p50_us = 1000, p99_us = 1000, p999_us = 1000, max_us = 1000 },
    wall = { n = 999, p50_us = 1012.4, p99_us = 1480, p999_us = 2900.4, max_us = 4100 } })
  T.eq(line, "MotionControl period main.m.redundancy: nominal 1.000 ms; sim n 999 p50 1.000 ms p99 1.000 ms "
    .. "max 1.000 ms; wall n 999 p50 1.012 ms p99 1.480 ms p999 2.900 ms max 4.100 ms")
end)

return suite:run(...)
