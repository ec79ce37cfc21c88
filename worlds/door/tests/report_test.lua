-- The door world's report (its descriptor's, worlds/door/world.lua) in `dca run --sim`: the control periods of MotionControl
-- in the summary (which leaves, the line the bench reads). The figures themselves come from the nodes'
-- `stats` (tests/host/node_test.cpp, timers_test.cpp); tests/bench/motion_period_bench.lua runs the door.
local T = require "dca.testing"
local suite = T.suite("door")

local src = T.src
local worlds = require "dca.worlds"

suite:case("the_period_leaves_of_the_door_are_motioncontrols_three_controllers", function()
  local door = worlds.descriptor("door").report
  local spec, err = require("dca.load").spec(src .. "/worlds/door/systems/door_open.dca")
  T.ok(spec, tostring(err))
  T.eq(door.leaves(spec), { "main.dooropensyst.motionctrl.xr4000", "main.dooropensyst.motionctrl.puma",
                            "main.dooropensyst.motionctrl.redundancy" })
  T.eq(door.leaves(spec, "NoSuchGroup"), {})
end)

suite:case("the_door_world_selects_the_door_report_and_others_none", function()
  T.eq(worlds.descriptor("door").report.head({ door_angle = 0 }), { "door opened to 0.0 deg" })
  T.eq(worlds.descriptor("nosuchworld").report.head({ door_angle = 1 }), {})
  T.eq(worlds.resolve(), "door", "the default world")
  -- its status topics are named as its signals' live topics and recorded channels
  T.eq(worlds.descriptor("door").topics[1].topic, "/world/door/angle")
end)

suite:case("a_bad_world_option_is_refused_with_what_it_takes", function()
  local ok, err = worlds.check("door", { "door_width=2" })
  T.eq(ok, nil)
  T.contains(err, "world option door_width is out of its range (0.5-1.5): 2")
  ok, err = worlds.check("door", { "no_such=1" })
  T.contains(err, "world 'door' has no option 'no_such' (its options: door_width, jammed")
  T.eq(worlds.check("door", { "jammed", "door_width=0.9" }), true)
end)

suite:case("the_period_line_gives_both_clocks_in_ms", function()
  local door = worlds.descriptor("door").report
  local line = door.period_line("main.m.redundancy", {
    name = "main.m.redundancy", period_s = 0.001,
    clock = { n = 999, p50_us = 1000, p99_us = 1000, p999_us = 1000, max_us = 1000 },
    wall = { n = 999, p50_us = 1012.4, p99_us = 1480, p999_us = 2900.4, max_us = 4100 } })
  T.eq(line, "MotionControl period main.m.redundancy: nominal 1.000 ms; sim n 999 p50 1.000 ms p99 1.000 ms "
    .. "max 1.000 ms; wall n 999 p50 1.012 ms p99 1.480 ms p999 2.900 ms max 4.100 ms")
end)

return suite:run(...)
