-- The door system in simulated time (real backend): the host running manipulation (the arm's controller,
-- the DoorOpenSystem supervisor) is lost mid-approach, its daemon and processes killed by SIGKILL. The root
-- ends ABORTED naming that host, and the arm stops: with no controller left to refresh it, the world's drive
-- watchdog takes the arm command as zero (after 50 ms), so the joints stop moving. The world runs on host
-- platform here, so that it outlives the loss.
local S = require "dca.scenario"
S.backends = { "real" }
local door = dofile((os.getenv("DCA_SOURCE_DIR") or ".") .. "/tests/support/door_scenario.lua")
local sys = door.system(S, { world_host = "platform" })
local VS = "main.dooropensyst.visualserv"
local norm = door.norm
local function dist(a, b)
  local s = 0
  for i = 1, math.max(#a, #b) do s = s + math.abs((a[i] or 0) - (b[i] or 0)) end
  return s
end

local t_loss
S.step("the tree comes up on three hosts on the simulated clock, the world on platform", function()
  sys:up(60)
  S.eq(sys:host("main.dooropensyst.motionctrl.puma"), "manipulation")
end)

S.step("the approach runs and the arm moves", function()
  sys:run()
  sys:wait_state(VS, "running", 30)
  sys:wait_world("the arm commanded and moving", function()
    return norm(sys:world_read("arm.cmd_qd")) > 1e-3 and norm(sys:world_read("arm.qd")) > 1e-3
  end, 30)
end)

S.step("host manipulation is lost: the root ends ABORTED naming it", function()
  sys:lose_host("manipulation")
  t_loss = sys:world_status().t
  local out = sys:wait_outcome(30)
  S.eq(out.type, "aborted")
  S.eq(sys:host(out.path), "manipulation", "the process named runs on manipulation: " .. tostring(out.path))
  S.contains(out.reason, "host manipulation lost")
end)

-- (The arm's state from the world's status, which is the state at its time: the sensor outputs, `world_read`,
-- hold what the world last published, at the last tick with a node due, and once the tree is gone only an idle
-- tick, every simulated second, has one.)
S.step("the arm stops: its joint velocities go to zero and its joints no longer move (after a 0.5 s settle)", function()
  local st = sys:wait_world("0.5 s of simulated time after the loss", function(s) return s.t >= t_loss + 0.5 end, 30)
  local q0 = st.arm_q
  S.ok(norm(st.arm_qd) < 1e-4, "arm.qd " .. S.show(st.arm_qd) .. " at " .. st.t .. " s")
  local t1 = st.t
  st = sys:wait_world("0.5 s more", function(s) return s.t >= t1 + 0.5 end, 30)
  S.ok(dist(q0, st.arm_q) < 1e-5, "arm.q " .. S.show(q0) .. " -> " .. S.show(st.arm_q))
  S.ok(norm(st.arm_qd) < 1e-4, "arm.qd " .. S.show(st.arm_qd) .. " at " .. st.t .. " s")
end)
return S.finish()
