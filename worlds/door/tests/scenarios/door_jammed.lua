-- The door system in simulated time (real backend), its handle jammed (the door world's option `jammed`,
-- `--world-opt jammed`): PressHandle presses until its force limit without the handle giving way and ends
-- ABORTED; the system aborts with that reason (naming main.dooropensyst.presshandle and the force limit), and
-- the door stays shut.
local S = require "dca.scenario"
S.backends = { "real" }
local door = dofile((os.getenv("DCA_SOURCE_DIR") or ".") .. "/tests/support/door_scenario.lua")
local sys = door.system(S, { world_opts = { "jammed" } })
local PH = "main.dooropensyst.presshandle"

door.up(S, sys, "the tree comes up on three hosts with the jammed world")

S.step("the robot reaches and grasps the handle; PressHandle runs", function()
  sys:run()
  sys:wait_state(PH, "running", 60)
end)

S.step("PressHandle stops at its force limit: the system aborts with that reason", function()
  local out = sys:wait_outcome(60)
  S.eq(out.type, "aborted")
  S.eq(out.path, PH)
  S.contains(out.reason, "handle jammed")
  S.contains(out.reason, " N reached")
end)

S.step("the door stays shut", function()
  local st = sys:world_status()
  S.ok(st.latched == true, "the latch holds: " .. S.show(st.latched))
  S.ok(math.abs(tonumber(st.door_angle) or 1) < math.rad(1), "door angle " .. tostring(st.door_angle))
  local t1 = st.t
  st = sys:wait_world("0.5 s more", function(s) return s.t >= t1 + 0.5 end, 30)
  S.ok(st.latched == true and math.abs(tonumber(st.door_angle) or 1) < math.rad(1),
    "still shut: angle " .. tostring(st.door_angle))
end)
return S.finish()
