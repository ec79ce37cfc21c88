-- A node that stalls in simulated time (ARCHITECTURE.md "Time", "A dropped node"): VisualServoing's process is
-- stopped (SIGSTOP) at a fixed tick, mid-approach, in the door system with a restart policy on its group (as
-- worlds/door/tests/scenarios/door_crash_restart.lua). The clock master drops it when its advance is not answered within the
-- tick timeout (here 3 s of wall time) and tells it (its clock channel closed); its supervisor, told by the
-- barrier to wait for the exit of a lost leaf whose process lives on, kills it (SIGKILL), hears its exit, and
-- the policy restarts it within that tick; its exit says the stall, then the kill. The door still opens. (Before: the supervisor waited for an exit
-- that never came, and the run stalled.)
local S = require "dca.scenario"
local T = require "dca.testing"
S.backends = { "real" }
local door = dofile((os.getenv("DCA_SOURCE_DIR") or ".") .. "/tests/support/door_scenario.lua")
local file, opts = door.variant("DoorOpenSystem", "supervision { strategy one_for_one; restart on crash; }")
opts.tick_timeout = 3000
local sys = door.system(S, opts)
local VS = door.VS

door.up(S, sys, "the tree comes up on three hosts on the simulated clock, with the world")
T.cleanup()  -- the variant's file
local at = door.held(S, sys, 2.0)

S.step("VisualServoing stalls (SIGSTOP): dropped from the clock, killed by its supervisor, restarted", function()
  sys:freeze(VS)
  sys:world_hold_at(at.t + 0.02, 60)
  local st = sys:world_status()
  S.ok(#st.dropped >= 1 and st.dropped[#st.dropped]:find(VS, 1, true), "dropped: " .. S.show(st.dropped))
  S.eq(sys:state(VS), "running")
  S.ok(sys:pid(VS) ~= at.pid, "a new process")
  S.eq(sys.outcome, nil, "the task runs on")
  -- its end names the cause first, then the kill (before: only "killed by SIGKILL", dca's own kill)
  local killed
  for _, l in ipairs(sys:transitions()) do
    killed = killed or (l:find(VS .. ": exited: dropped by the clock master: did not answer the advance to ", 1, true)
      and l:find("within 3000 ms); killed by SIGKILL", 1, true) and l)
  end
  S.ok(killed, "its old process was killed, and the cause said: " .. S.show(sys:transitions()))
end)

door.opens(S, sys)
return S.finish()
