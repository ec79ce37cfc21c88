-- The door system in simulated time (real backend): VisualServoing crashes (SIGSEGV) mid-approach. The system
-- aborts naming it and the signal, the running processes are stopped most recently started first, and the
-- base and arm commands the world holds are zero within one control period (10 ms of simulated time) and stay
-- zero: the base no longer moves.
--
-- Lock-step (ARCHITECTURE.md "Time"): time is held at a fixed tick (2 s) and VisualServoing is killed there;
-- when time flows again the clock master finds it lost at its next tick (10 ms later at most), and the
-- supervisors handle the loss at that tick before the world moves on: the aborts and the drives' zero
-- commands all happen at that one tick, the same in every run.
local S = require "dca.scenario"
S.backends = { "real" }
local door = dofile((os.getenv("DCA_SOURCE_DIR") or ".") .. "/tests/support/door_scenario.lua")
local sys = door.system(S)
local VS = "main.dooropensyst.visualserv"
local norm = door.norm

local t_crash, pose0
door.up(S, sys, "the tree comes up on three hosts on the simulated clock, with the world")

S.step("VisualServoing runs and the base moves (time held at 2 s)", function()
  local p0 = sys:world_status().base_pose
  sys:run()
  sys:wait_state(VS, "running", 30)
  t_crash = sys:world_hold_at(2.0, 60)
  local p = sys:world_status().base_pose
  S.ok(math.abs(p[1] - p0[1]) + math.abs(p[2] - p0[2]) > 0.05, "the base moved: " .. S.show(p0) .. " -> " .. S.show(p))
  S.ok(norm(sys:world_read("base.cmd_vel")) > 1e-4, "base.cmd_vel " .. S.show(sys:world_read("base.cmd_vel")))
end)

S.step("VisualServoing crashes (SIGSEGV): ABORTED naming it and the signal", function()
  sys:kill(VS, "SEGV")
  sys:world_hold_at(t_crash + 0.02, 60)  -- the loss is found at the next tick; the world holds after it
  local out = sys:wait_outcome(30)
  S.eq(out.type, "aborted")
  S.eq(out.path, VS)
  S.contains(out.reason, "SIGSEGV")
end)

S.step("the stops: innermost cascade first (camera by ',', distdetect by '#'), the motion controller last; "
  .. "each group's leaves LIFO", function()
  local aborting, runs, stops = {}, {}, {}
  for _, l in ipairs(sys:transitions()) do
    local child = l:match("^main%.dooropensyst%.([%w_]+): aborting$")
    if child then aborting[#aborting + 1] = child end
    local g, leaf, what = l:match("^main%.dooropensyst%.([%w_]+)%.([%w_]+): (%a+)$")
    if g and what == "running" then runs[g] = runs[g] or {} table.insert(runs[g], leaf) end
    if g and what == "aborting" then stops[g] = stops[g] or {} table.insert(stops[g], leaf) end
  end
  S.eq(aborting, { "camera", "distdetect", "motionctrl" })
  for _, g in ipairs({ "distdetect", "motionctrl" }) do
    local rev = {}
    for i = #runs[g], 1, -1 do rev[#rev + 1] = runs[g][i] end
    S.eq(stops[g], rev, g .. ": stopped in reverse order of their start")
  end
end)

S.step("the world holds zero base and arm commands 20 ms after the crash (found within 10 ms)", function()
  local st = sys:world_status()
  S.ok(math.abs(st.t - t_crash - 0.02) < 1e-9, "time held: " .. tostring(st.t) .. " vs " .. tostring(t_crash))
  S.ok(norm(sys:world_read("base.cmd_vel")) == 0, "base.cmd_vel " .. S.show(sys:world_read("base.cmd_vel")))
  S.ok(norm(sys:world_read("arm.cmd_qd")) == 0, "arm.cmd_qd " .. S.show(sys:world_read("arm.cmd_qd")))
end)

S.step("time flows on: the commands stay zero and the base stops (no motion after a 0.5 s settle)", function()
  sys:world_go()
  local st = sys:wait_world("0.5 s more", function(s) return s.t >= t_crash + 0.5 end, 30)
  pose0 = st.base_pose
  sys:wait_world("1 s more", function(s) return s.t >= t_crash + 1.0 end, 30)
  local p = sys:world_status().base_pose
  S.ok(math.abs(p[1] - pose0[1]) + math.abs(p[2] - pose0[2]) + math.abs(p[3] - pose0[3]) < 1e-5,
    "base pose " .. S.show(pose0) .. " -> " .. S.show(p))
  -- (the base's velocity at this time from the status; the base.vel output holds its last published sample)
  local vel = sys:world_status().base_vel
  S.ok(norm(vel) < 1e-4, "base.vel " .. S.show(vel))
  S.ok(norm(sys:world_read("base.cmd_vel")) == 0, "base.cmd_vel " .. S.show(sys:world_read("base.cmd_vel")))
  S.ok(norm(sys:world_read("arm.cmd_qd")) == 0, "arm.cmd_qd " .. S.show(sys:world_read("arm.cmd_qd")))
end)
return S.finish()
