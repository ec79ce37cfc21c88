-- A node that lost its control channel but lives on (ARCHITECTURE.md "Supervision policies", Faults), with real
-- processes: the supervisor's end of main.a's channel is closed; no exit comes within exit_grace, so the node
-- is killed (SIGKILL) and only then its end told as `lost`, and the root's policy restarts it: afterwards one
-- process of main.a exists, a new one, and the old one is gone.
local S = require "dca.scenario"
local core = require "dca.core"
local src = os.getenv("DCA_SOURCE_DIR") or "."
S.backends = { "real" }   -- (the memory cluster has no channel apart from its process)
local sys = S.system(src .. "/scripts/systems/test_node_lost.dca")

S.step("main.a's channel is lost while its node lives on: killed, then restarted as lost", function()
  sys:up()
  sys:run()
  sys:wait_state("main.a", "running", 10)
  local old = sys:pid("main.a")
  local proc
  for _, p in pairs(sys.rt.by_child) do if p.path == "main.a" then proc = p end end
  S.ok(proc, "the root's process of main.a")
  sys.rt.opts.exit_grace = 0.3
  local from = #sys:transitions()
  proc.ch:close()
  local line = sys:wait_restart("main.a", 20, from)
  S.contains(line, "main.a: restarted 1/3 in 60 s")
  S.eq(#sys:lines_matching("^main%.a: exited: node lost on host h1", from), 1)
  S.ok(not core.kill(old, 0), "the old process is gone")
  local now = sys:pid("main.a")
  S.ok(now and now ~= old, "a new process")
  local n = 0
  for _, pid in ipairs(sys:alive()) do
    local f = io.open("/proc/" .. pid .. "/cmdline")
    local cmd = f and f:read("a") or ""
    if f then f:close() end
    if cmd:find("main.a", 1, true) then n = n + 1 end
  end
  S.eq(n, 1, "one process of main.a")
  sys:wait_state("main.a", "running", 10)
end)
return S.finish()
