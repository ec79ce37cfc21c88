-- Restart of a leaf in simulated time (ARCHITECTURE.md "Time", "A restart in simulated time"): the door system
-- (real backend, seed 1) holds its time at a fixed tick mid-approach (2 s) and VisualServoing is restarted
-- there: a fresh process, its links made again both ways (from the camera, to the motion controller), run
-- again (Init, Run at 2 s). Its links' counts start afresh at the clock master, so its new links' samples are
-- delivered as any others and the task carries on: the door opens past 70 degrees, the run ends DONE.
--
-- `dca scenario --trace FILE` writes the run's trace (door.restart_repeat runs this twice, and once more with
-- `--placement host`, and compares the traces: a restart at a defined tick repeats exactly).
local S = require "dca.scenario"
S.backends = { "real" }
local door = dofile((os.getenv("DCA_SOURCE_DIR") or ".") .. "/tests/support/door_scenario.lua")
local sys = door.system(S)
local VS = door.VS

door.up(S, sys, "the tree comes up on three hosts on the simulated clock, with the world")
local at = door.held(S, sys, 2.0)

S.step("restart(visualserv) at the held tick: a new process, running again at that tick", function()
  local res
  sys.sup:restart(VS, function(ok, err) res = { ok, err } end)
  sys:wait("the restart", function() return res ~= nil end, 60)
  S.ok(res[1], "restarted: " .. tostring(res[2]))
  -- (under a shared placement, `dca scenario --placement group|host`, a fresh instance in the same node)
  if (S.placement or "process") == "process" then S.ok(sys:pid(VS) ~= at.pid, "a new process") end
  S.eq(sys:state(VS), "running")
  S.eq(sys:world_status().t, at.t, "time did not move during the restart")
end)

door.opens(S, sys)
return S.finish()
