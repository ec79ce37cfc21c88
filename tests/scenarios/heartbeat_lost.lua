-- A supervisor, then a whole host's daemon, stops answering without closing its sockets (SIGSTOP): the
-- heartbeat makes the silence an ABORTED event at the parent naming the host, and what the silent
-- supervisor had started is ended. (The detector's level is out of reach, as in host_lost.lua.)
local S = require "dca.scenario"
local T = require "dca.testing"
local tmp = dofile(T.src .. "/tests/scenarios/lib/unreachable_level.lua")()
local sys = S.system(tmp)

local function flowing(s)
  s:up()
  s:run()
  s:wait_read("main.chain.det.level", "In", function(v) return (tonumber(v) or 0) >= 3 end, 1)
end

S.step("up and running, data flowing", function() flowing(sys) end)

S.step("the supervisor of det is stopped (SIGSTOP): ABORTED at chain naming it and host manip", function()
  sys:freeze("main.chain.det")
  local out = sys:wait_outcome(10)
  S.eq(out.type, "aborted")
  S.eq(out.path, "main.chain.det")
  S.contains(out.reason, "supervisor lost on host manip")
  S.eq(sys:state("main.chain.det"), "lost")
  S.ok(sys:state("main.chain.vel") ~= "running", "the command source on platform was stopped")
end)

S.step("the silent supervisor and the detector it had started are ended", function()
  sys:wait("main.chain.det and its leaf gone", function()
    return not sys:exists("main.chain.det") and not sys:exists("main.chain.det.level")
  end, 10)
end)

S.step("stop leaves no process behind", function() S.ok(sys:stop(), "all stopped") end)

local sys2 = S.system(tmp)
T.cleanup()

S.step("a second system up and running", function() flowing(sys2) end)

S.step("host manip's daemon is stopped (SIGSTOP): ABORTED naming host manip", function()
  sys2:freeze_host("manip")
  local out = sys2:wait_outcome(20) -- detection (5 s of silence), then the stop of arm on manip times out (5 s)
  S.eq(out.type, "aborted")
  S.eq(sys2:host(out.path), "manip", "the process named runs on manip: " .. tostring(out.path))
  S.contains(out.reason, "host manip")
  S.ok(sys2:state("main.chain.vel") ~= "running", "the command source on platform was stopped")
end)

S.step("the silent host is taken down; stop leaves no process behind", function()
  sys2:lose_host("manip")
  S.ok(sys2:stop(), "all stopped")
end)
return S.finish()
