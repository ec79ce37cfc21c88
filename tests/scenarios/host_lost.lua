-- A host is lost mid-run: the parent of what ran there hears ABORTED naming the host, and the rest stops.
-- The detector's level is out of reach here (the file's 30 is reached 0.3 s after the run: in real time
-- nothing would order the loss before it), so only the loss can end the run.
local S = require "dca.scenario"
local T = require "dca.testing"
local sys = S.system(dofile(T.src .. "/tests/scenarios/lib/unreachable_level.lua")())
T.cleanup()

S.step("three hosts up, connections resolved through external_io controller to controller", function()
  sys:up()
  if sys.backend == "memory" then
    local conns = sys:node("main.chain.src.count").conns
    S.eq(conns[1], { out = "Count", to = "main.chain.det.level", ["in"] = "In", set = "main.chain:src[run]" })
    S.eq(sys:node("main.chain.vel").conns[1].to, "main.chain.arm")
  end
  S.eq(sys:state("main.chain.det.level"), "inactive")
end)

S.step("data flows host to host while it runs", function()
  sys:run()
  sys:wait_read("main.chain.det.level", "In", function(v) return (tonumber(v) or 0) >= 5 end, 1)
end)

S.step("host manip is lost: ABORTED naming it", function()
  sys:lose_host("manip")
  local out = sys:wait_outcome(5)
  S.eq(out.type, "aborted")
  S.eq(sys:host(out.path), "manip", "the process named runs on manip: " .. tostring(out.path))
  S.contains(out.reason, "host manip lost")
  S.ok(sys:state("main.chain.vel") ~= "running", "the command source on platform was stopped")
end)
return S.finish()
