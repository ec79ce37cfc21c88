-- The simulated clock's commands in the REPL (docs/time.md "Pace"): through the root supervisor to the world, the
-- clock master. On the door system (seed 1), time held at 1 s: clock() says the world's time; pause holds it
-- (t and steps do not move across world requests); step() is exactly one tick; speed() takes 0.1 to 10 or "max"
-- and a change moves no time; step("event") runs to the end of the next tick with a barrier (an event: the
-- supervisors' transitions) and holds there; resume() runs the system to DONE. No wall-clock assertion: the pace
-- itself is tests/host/lockstep_test.cpp (fake wall clock).
local T = require "dca.testing"
local suite = T.suite("pace")

local dca, src = T.exe, T.src

local SCENARIO = [[
local S = require "dca.scenario"
S.backends = { "real" }
local door = dofile(%q .. "/tests/support/door_scenario.lua")
local sys = door.system(S)
local sformat = string.format
local function say(line) return sys:repl(line) end
door.up(S, sys, "the door system up, time at 0, unpaced (a scenario's world runs as fast as it can)")
local t0
S.step("held at 1 s: clock() gives the world's time, paused", function()
  sys:world_hold_when(1.0)
  sys:run()
  t0 = sys:world_wait_held(1.0, 60)
  S.eq(sys:world_status().speed, 0)
  S.contains(say("clock()"), sformat("t = %%.3f s, paused", t0))
end)
S.step("pause holds time: t and steps stay across world requests", function()
  S.contains(say("pause"), sformat("t = %%.3f s, paused", t0))
  local st = sys:world_status()
  for _ = 1, 5 do
    local s = sys:world_status()
    S.eq(s.t, st.t)
    S.eq(s.steps, st.steps)
    S.eq(s.running, false)
  end
end)
S.step("step() is one tick, then time holds", function()
  local st = sys:world_status()
  local period = st.t / st.steps
  for i = 1, 3 do
    local out = say(i == 1 and "step" or "step()")
    local s = sys:world_status()
    S.eq(s.steps, st.steps + i)
    S.eq(s.running, false)
    S.ok(math.abs(s.t - (st.t + i * period)) < 1e-9, "one period more: " .. s.t)
    S.contains(out, sformat("t = %%.3f s, paused", s.t))
  end
end)
S.step("speed(): 0.1 to 10 or max, refused otherwise; a change while paused moves no time", function()
  local st = sys:world_status()
  S.contains(say("speed(2)"), "paused")
  S.eq(sys:world_status().speed, 2)
  S.contains(say("speed(0.1)"), "paused")
  S.eq(sys:world_status().speed, 0.1)
  S.contains(say("speed(20)"), "speed: 0.1 to 10")
  S.contains(say("speed('fast')"), "speed: 0.1 to 10")
  S.eq(sys:world_status().speed, 0.1)
  S.contains(say("speed('max')"), "paused")
  local s = sys:world_status()
  S.eq(s.speed, 0)
  S.eq(s.t, st.t)
  S.eq(s.steps, st.steps)
end)
S.step("step('event') runs to the tick of the next event and holds there, its barrier done", function()
  local st = sys:world_status()
  S.contains(say("step('event')"), "running")
  local s = sys:wait_world("held after an event", function(w) return not w.running and w.settled end, 60)
  S.ok(s.barriers > st.barriers, "a barrier: " .. st.barriers .. " -> " .. s.barriers)
  S.ok(s.t > st.t, "time ran: " .. st.t .. " -> " .. s.t)
  for _ = 1, 3 do S.eq(sys:world_status().t, s.t) end
  S.contains(say("step('next')"), "step(): one tick")
end)
S.step("resume() runs the system to DONE", function()
  S.contains(say("resume"), "running at max speed")
  S.eq(sys:wait_outcome(120).type, "done")
end)
return S.finish()
]]

suite:case("pause_step_speed_and_step_to_the_next_event_from_the_repl", function()
  local dir = T.tmpdir()
  local file = T.write(dir .. "/pace.lua", string.format(SCENARIO, src))
  local out, rc = T.sh("timeout 250 " .. dca .. " scenario --backend real " .. file)
  T.kept_logs(out)
  T.eq(rc, 0, "the scenario passes\n" .. out)
end)

return suite:run(...)
