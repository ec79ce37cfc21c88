-- A hardware-facing leaf restarted (docs/time.md, "Hardware-facing outputs during a
-- restart"): the door system with a restart policy on its MotionControl group, whose XR4000Ctrl drives the base
-- (its output Cmd is the device port base.cmd_vel). Time is held mid-approach at 2 s, the base moving. What the
-- world applies, step by step (a command written at tick t acts in the step from t; the world reads it at t+1;
-- world_status().base_cmd is the base command its last step applied):
--   1. XR4000Ctrl crashes (SIGSEGV) at 2 s, after its command of 2.000 s, which acts in the step from 2.000 s.
--      The master finds its node lost at its next tick, 2.010 s, and the world drops the base command that came
--      from it at once (as a robot's driver does on losing its writer), so the step from 2.010 s applies zero.
--      The policy restarts it in that tick's barrier; the new process's first command, of 2.020 s, is zero too
--      (its Vel input has nothing yet), and its second, of 2.030 s, drives the base again.
--   2. XR4000Ctrl restarted by hand at 3 s (time held there). The samples its old process wrote at 3 s, its
--      MainCalc's and the zero its Stop() writes, go with its link; the new process subscribing at 3 s drops
--      the old one's command, so the step from 3 s applies zero, and so does the new process's first.
-- So from the tick a drive is lost or restarted, it is at zero until its new process drives it.
local S = require "dca.scenario"
local T = require "dca.testing"
S.backends = { "real" }
local door = dofile((os.getenv("DCA_SOURCE_DIR") or ".") .. "/tests/support/door_scenario.lua")
local file, opts = door.variant("MotionControl", "supervision { strategy one_for_one; restart on crash; }")
opts.seed = tonumber(os.getenv("DCA_SEED")) or 1
local sys = door.system(S, opts)
local XR = "main.dooropensyst.motionctrl.xr4000"
local norm = door.norm

door.up(S, sys, "the tree comes up on three hosts on the simulated clock, with the world")
T.cleanup()  -- the variant's file
local at = door.held(S, sys, 2.0)

local function near(a, b, tol)
  for i = 1, 3 do if math.abs((a[i] or 0) - (b[i] or 0)) > tol then return false end end
  return true
end

-- the base command the world applied in its last step (after its watchdog)
local function applied() return sys:world_status().base_cmd end

S.step("the base drive crashes (SIGSEGV) at 2 s: lost and restarted at 2.010 s", function()
  local pid = sys:pid(XR)
  sys:kill(XR, "SEGV")
  local t = sys:world_hold_at(at.t + 0.01, 60)
  local cmd = sys:world_read("base.cmd_vel")  -- its last command, of 2.000 s
  S.eq(math.floor(t * 1e3 + 0.5), 2010, "held at the tick the loss is found")
  S.eq(sys:state(XR), "running")
  S.ok(sys:pid(XR) ~= pid, "a new process")
  S.eq(sys.outcome, nil, "the task runs on")
  local restarted
  for _, l in ipairs(sys:transitions()) do if l:find(XR .. ": restarted", 1, true) then restarted = l end end
  S.ok(restarted, "a transition line says " .. XR .. " restarted")
  -- the step from 2.000 s applied the crashed process's last command, written before the crash
  S.ok(norm(cmd) > 0.1, "base.cmd_vel of 2.000 s " .. S.show(cmd))
  S.ok(near(applied(), cmd, 0), "applied " .. S.show(applied()) .. " at the command " .. S.show(cmd))
end)

S.step("from the loss's tick, 2.010 s, the base is at zero until the new process drives it", function()
  sys:world_hold_at(at.t + 0.02, 60)
  S.ok(norm(applied()) < 1e-9, "zero in the step from 2.010 s: " .. S.show(applied()))
  sys:world_hold_at(at.t + 0.03, 60)
  S.ok(norm(applied()) < 1e-9, "zero in the step from 2.020 s (the new process's first): " .. S.show(applied()))
  S.eq(norm(sys:world_read("base.cmd_vel")), 0, "the new process's first command")
  sys:world_hold_at(at.t + 0.04, 60)
  S.ok(norm(applied()) > 0.1, "its second command drives the base again: " .. S.show(applied()))
end)

S.step("restart(xr4000) by hand at 3 s: zero from the step from 3 s", function()
  sys:world_hold_at(3.0, 60)
  local last = sys:world_read("base.cmd_vel")    -- written at 2.990 s, applied in the step from 2.990 s
  S.ok(norm(last) > 0.1, "a command at 2.990 s: " .. S.show(last))
  S.ok(near(applied(), last, 0), "applied " .. S.show(applied()) .. " at it")
  local pid = sys:pid(XR)
  local res
  sys.sup:restart(XR, function(ok, err) res = { ok, err } end)
  sys:wait("the restart", function() return res ~= nil end, 60)
  S.ok(res[1], "restarted: " .. tostring(res[2]))
  S.ok(sys:pid(XR) ~= pid, "a new process")
  S.eq(sys:world_status().t, 3.0, "time did not move during the restart")
  sys:world_hold_at(3.01, 60)
  S.ok(norm(applied()) < 1e-9, "zero in the step from 3 s: " .. S.show(applied()))
  sys:world_hold_at(3.02, 60)
  S.ok(norm(applied()) < 1e-9, "zero in the step from 3.010 s (the new process's first): " .. S.show(applied()))
  S.eq(norm(sys:world_read("base.cmd_vel")), 0, "the new process's first command")
end)

door.opens(S, sys)
return S.finish()
