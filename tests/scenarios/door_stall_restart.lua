-- A node that stalls in simulated time (ARCHITECTURE.md "Time", "A dropped node"): VisualServoing's process is
-- stopped (SIGSTOP) at a fixed tick, mid-approach, in the door system with a restart policy on its group (as
-- tests/scenarios/door_crash_restart.lua). The clock master drops it when its advance is not answered within the
-- tick timeout (here 1 s of wall time) and tells it (its clock channel closed); its supervisor, told by the
-- barrier to wait for the exit of a lost leaf whose process lives on, kills it (SIGKILL), hears its exit, and
-- the policy restarts it within that tick. The door still opens. (Before: the supervisor waited for an exit
-- that never came, and the run stalled.)
local S = require "dca.scenario"
S.backends = { "real" }
local door = dofile((os.getenv("DCA_SOURCE_DIR") or ".") .. "/tests/support/door_scenario.lua")
local file, opts = door.variant("DoorOpenSystem", "supervision { strategy one_for_one; restart on crash; }")
opts.tick_timeout = 1000
local sys = door.system(S, opts)
local VS = "main.dooropensyst.visualserv"
local t_stop, pid0

door.up(S, sys, "the tree comes up on three hosts on the simulated clock, with the world")
os.remove(file)

S.step("VisualServoing runs (time held at 2 s)", function()
  sys:run()
  sys:wait_state(VS, "running", 30)
  t_stop = sys:world_hold_at(2.0, 60)
  pid0 = sys:pid(VS)
end)

S.step("VisualServoing stalls (SIGSTOP): dropped from the clock, killed by its supervisor, restarted", function()
  sys:freeze(VS)
  sys:world_hold_at(t_stop + 0.02, 60)
  local st = sys:world_status()
  S.ok(#st.dropped >= 1 and st.dropped[#st.dropped]:find(VS, 1, true), "dropped: " .. S.show(st.dropped))
  S.eq(sys:state(VS), "running")
  S.ok(sys:pid(VS) ~= pid0, "a new process")
  S.eq(sys.outcome, nil, "the task runs on")
  local killed
  for _, l in ipairs(sys:transitions()) do killed = killed or l:find(VS .. ": exited: killed by SIGKILL", 1, true) end
  S.ok(killed, "its old process was killed")
end)

S.step("time flows on: the door opens to at least 70 degrees and the task ends DONE", function()
  sys:world_go()
  local out = sys:wait_outcome(300)
  S.eq(out.type, "done", "outcome " .. S.show(out))
  local angle = math.deg(sys:world_status().door_angle)
  S.ok(angle >= 70, "door angle " .. tostring(angle))
end)
return S.finish()
