-- A host is lost mid-run: the parent of what ran there hears ABORTED naming the host, and the rest stops.
local S = require "dca.scenario"
local src = os.getenv("DCA_SOURCE_DIR") or "."
local sys = S.system(src .. "/scripts/systems/test_three_hosts.dca")

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
  sys:settle(0.1)
  S.ok((sys:read("main.chain.det.level", "In") or 0) >= 5, "the detector receives the count")
end)

S.step("host manip is lost: ABORTED naming it", function()
  sys:lose_host("manip")
  local out = sys:wait_outcome(5)
  S.eq(out.type, "aborted")
  S.ok(out.path == "main.chain.det" or out.path == "main.chain.arm", "a process on manip: " .. tostring(out.path))
  S.contains(out.reason, "host manip lost")
  S.ok(sys:state("main.chain.vel") ~= "running", "the command source on platform was stopped")
end)
return S.finish()
