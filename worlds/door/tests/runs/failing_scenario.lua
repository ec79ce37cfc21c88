-- A scenario in simulated time that fails on purpose (worlds/door/tests/runs/scenario_rerun.sh, CTest door.failing_rerun):
-- the door system runs to a held tick (1 s) and a step asserts what is not so. dca scenario then prints the
-- seed, the trace file and the command that runs it again; that run fails the same way with the same trace.
-- Not in tests/scenarios/: it is not meant to pass.
local S = require "dca.scenario"
S.backends = { "real" }
local door = dofile((os.getenv("DCA_SOURCE_DIR") or ".") .. "/tests/support/door_scenario.lua")
local sys = door.system(S)
local VS = "main.dooropensyst.visualserv"

door.up(S, sys, "the tree comes up on three hosts on the simulated clock, with the world")

S.step("VisualServoing runs; time held at 1 s", function()
  sys:run()
  sys:wait_state(VS, "running", 30)
  sys:world_hold_at(1.0, 60)
end)

S.step("the base is past x = 5 m at 1 s (it is not: this step fails on purpose)", function()
  local p = sys:world_status().base_pose
  S.ok(p[1] > 5, string.format("base pose x = %.17g m, y = %.17g m", p[1], p[2]))
end)
return S.finish()
