-- A hardware-facing leaf restarted (issue 18; ARCHITECTURE.md "Time", "Hardware-facing outputs during a
-- restart"): the door system with a restart policy on its MotionControl group, whose XR4000Ctrl drives the base
-- (its output Cmd is the device port base.cmd_vel). Time is held mid-approach at 2 s, the base moving. What the
-- world applies, step by step (a command written at tick t acts in the step from t; the world reads it at t+1):
--   1. XR4000Ctrl crashes (SIGSEGV) at 2 s. It writes nothing more; the master finds its node lost at its next
--      tick, 2.010 s, and the policy restarts it in that tick's barrier; the new process's first MainCalc is at
--      2.020 s. So the world has no new base command for 20 ms and applies the crashed process's last one (of
--      2.000 s) in the steps from 2.000 and 2.010 s: inside the world's 50 ms drive watchdog (a command older than
--      that counts as zero), which therefore does not act. The new process's first command is zero (its Vel
--      input has nothing yet: what RedundancyResolution wrote at 2.010 s went to the old process), so the base is
--      commanded zero in the step from 2.020 s, and moves again from 2.030 s.
--   2. XR4000Ctrl restarted by hand at 3 s (time held there). The samples its old process wrote at 3 s, its
--      MainCalc's and the zero its Stop() writes, go with its link (the new process's link starts its counts
--      afresh), so the world applies the command of 2.990 s once more in the step from 3 s, then the new
--      process's first, zero, in the step from 3.010 s.
-- So during a restart a drive is never driven by anything but its old process's last command (for at most two
-- periods, well inside the watchdog) and then its new process's, which starts from zero.
local S = require "dca.scenario"
S.backends = { "real" }
local door = dofile((os.getenv("DCA_SOURCE_DIR") or ".") .. "/tests/support/door_scenario.lua")
local file, opts = door.variant("MotionControl", "supervision { strategy one_for_one; restart on crash; }")
opts.seed = tonumber(os.getenv("DCA_SEED")) or 1
local sys = door.system(S, opts)
local XR = "main.dooropensyst.motionctrl.xr4000"
local norm = door.norm

door.up(S, sys, "the tree comes up on three hosts on the simulated clock, with the world")
os.remove(file)
local at = door.held(S, sys, 2.0)

local function near(a, b, tol)
  for i = 1, 3 do if math.abs((a[i] or 0) - (b[i] or 0)) > tol then return false end end
  return true
end

local cmd
S.step("the base drive crashes (SIGSEGV) at 2 s: restarted at 2.010 s, the world keeps its last command", function()
  local pid = sys:pid(XR)
  sys:kill(XR, "SEGV")
  local t = sys:world_hold_at(at.t + 0.01, 60)
  S.eq(math.floor(t * 1e3 + 0.5), 2010, "held at the tick the loss is found")
  S.eq(sys:state(XR), "running")
  S.ok(sys:pid(XR) ~= pid, "a new process")
  S.eq(sys.outcome, nil, "the task runs on")
  local restarted
  for _, l in ipairs(sys:transitions()) do if l:find(XR .. ": restarted", 1, true) then restarted = l end end
  S.ok(restarted, "a transition line says " .. XR .. " restarted")
  -- the command the world took in last is the crashed process's last (2.000 s), not zero, and the base moves at it
  cmd = sys:world_read("base.cmd_vel")
  S.ok(norm(cmd) > 0.1, "base.cmd_vel " .. S.show(cmd))
  local vel = sys:world_status().base_vel
  S.ok(near(vel, cmd, 0.01), "base velocity " .. S.show(vel) .. " at the command " .. S.show(cmd))
end)

S.step("until 2.020 s the world holds that command; the new process's first, zero, acts from 2.020 s", function()
  sys:world_hold_at(at.t + 0.02, 60)
  local now = sys:world_read("base.cmd_vel")
  S.ok(near(now, cmd, 0), "the world still holds the command of 2.000 s: " .. S.show(now))
  local vel = sys:world_status().base_vel
  S.ok(near(vel, cmd, 0.01), "base velocity " .. S.show(vel) .. " at the command " .. S.show(cmd))
  sys:world_hold_at(at.t + 0.03, 60)
  now = sys:world_read("base.cmd_vel")
  S.eq(norm(now), 0, "the new process's first command: " .. S.show(now))
  sys:world_hold_at(at.t + 0.04, 60)
  now = sys:world_read("base.cmd_vel")
  S.ok(norm(now) > 0.1, "its second command drives the base again: " .. S.show(now))
end)

S.step("restart(xr4000) by hand at 3 s: the command of 2.990 s acts once more, then the new process's zero", function()
  sys:world_hold_at(2.99, 60)
  local before = sys:world_read("base.cmd_vel")  -- (written at 2.980 s)
  sys:world_hold_at(3.0, 60)
  local last = sys:world_read("base.cmd_vel")    -- written at 2.990 s
  S.ok(norm(last) > 0.1 and not near(last, before, 0), "a fresh command at 3 s: " .. S.show(last))
  local pid = sys:pid(XR)
  local res
  sys.sup:restart(XR, function(ok, err) res = { ok, err } end)
  sys:wait("the restart", function() return res ~= nil end, 60)
  S.ok(res[1], "restarted: " .. tostring(res[2]))
  S.ok(sys:pid(XR) ~= pid, "a new process")
  S.eq(sys:world_status().t, 3.0, "time did not move during the restart")
  sys:world_hold_at(3.01, 60)
  local now = sys:world_read("base.cmd_vel")
  S.ok(near(now, last, 0), "the command of 2.990 s again (the old process's last samples went with it): " ..
    S.show(now))
  sys:world_hold_at(3.02, 60)
  now = sys:world_read("base.cmd_vel")
  S.eq(norm(now), 0, "the new process's first command: " .. S.show(now))
end)

door.opens(S, sys)
return S.finish()
