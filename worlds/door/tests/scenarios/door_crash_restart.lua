-- The door survives a transient crash: the door system with a restart policy on its DoorOpenSystem
-- group (`supervision { strategy one_for_one; restart on crash; }`) in simulated time; VisualServoing crashes
-- (SIGSEGV) mid-approach, at a fixed tick (time held at 2 s, as worlds/door/tests/scenarios/door_crash.lua does). The clock
-- master finds its node lost at the next tick and the group's supervisor restarts it within that tick's barrier
-- (a fresh process, its links made again both ways, Init and Run at that tick): the algebra sees nothing and
-- the task carries on, the door opens to at least 70 degrees and the run ends DONE.
--   DCA_SEED=N (default 1) the world's seed; DCA_DOOR_POLICY=off: the same file without the section, which
--   aborts as door_crash.lua shows (ABORTED naming VisualServoing and the signal);
--   `dca scenario --trace FILE` the run's trace (door.crash_restart_repeat compares two runs).
local S = require "dca.scenario"
local T = require "dca.testing"
S.backends = { "real" }
local door = dofile((os.getenv("DCA_SOURCE_DIR") or ".") .. "/tests/support/door_scenario.lua")
local policy = os.getenv("DCA_DOOR_POLICY") ~= "off"
local file, opts = door.variant("DoorOpenSystem",
  policy and "supervision { strategy one_for_one; restart on crash; }" or "")
opts.seed = tonumber(os.getenv("DCA_SEED")) or 1
local sys = door.system(S, opts)
local VS = door.VS

door.up(S, sys, "the tree comes up on three hosts on the simulated clock, with the world")
T.cleanup()  -- the variant's file
local at = door.held(S, sys, 2.0)

if not policy then
  S.step("without the policy: VisualServoing's SIGSEGV aborts the task, naming it and the signal", function()
    sys:kill(VS, "SEGV")
    sys:world_hold_at(at.t + 0.02, 60)
    local out = sys:wait_outcome(30)
    S.eq(out.type, "aborted")
    S.eq(out.path, VS)
    S.contains(out.reason, "SIGSEGV")
  end)
  return S.finish()
end

S.step("VisualServoing crashes (SIGSEGV): restarted at the tick its loss is found, nothing else stops", function()
  sys:kill(VS, "SEGV")
  local t = sys:world_hold_at(at.t + 0.02, 60)
  S.eq(sys:state(VS), "running")
  S.ok(sys:pid(VS) ~= at.pid, "a new process: " .. tostring(sys:pid(VS)) .. " (was " .. tostring(at.pid) .. ")")
  S.eq(sys.outcome, nil, "the task runs on")
  local restarted, when
  for i, l in ipairs(sys:transitions()) do
    if l:find(VS .. ": restarted", 1, true) then restarted, when = l, sys:transition_at(i) end
  end
  S.ok(restarted, "a transition line says " .. VS .. " restarted")
  S.eq(sys:state("main.dooropensyst.camera"), "running", "its peer never stopped")
  S.ok(math.abs(t - at.t - 0.02) < 1e-9, "time held 20 ms after the crash: " .. tostring(t))
  -- at the tick its loss was found: VisualServoing's next tick (its period is 10 ms) after the kill at 2 s
  S.eq(math.floor((when or -1) * 1e3 + 0.5), 2010, "the restart's time (ms): " .. tostring(when))
end)

door.opens(S, sys)
return S.finish()
