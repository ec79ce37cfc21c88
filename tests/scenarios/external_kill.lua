-- A SIGSEGV sent from outside is nobody's crash (docs/placement.md "Crash containment"): `hang` blocks in its
-- MainCalc, so its code runs when `kill -SEGV` ends its process. With one process per leaf the run ends ABORTED
-- naming hang (its own process died). In a shared node (`--placement group|host`) the node's crash note must
-- not blame hang for a signal it did not cause: the leaves are reported in path order (alpha first), and the
-- reason does not say "it crashed in".
local S = require "dca.scenario"
S.backends = { "real" }
local src = os.getenv("DCA_SOURCE_DIR") or "."
local sys = S.system(src .. "/scripts/systems/test_external_kill.dca")
local HANG = "main.work.hang"
local shared = (S.placement or "process") ~= "process"

-- The crash note of the shared node hosting `path` (host/node.h): the leaf whose code runs now.
local function note_of(path)
  local dir = os.getenv("XDG_RUNTIME_DIR") or ""
  local f = io.open(dir .. "/node-" .. tostring(sys:pid(path)) .. ".crash", "rb")
  if not f then return "" end
  local s = f:read("a") or ""
  f:close()
  return (s:match("^[^%z]*"))
end

S.step("up and running; hang blocks in its MainCalc", function()
  sys:up()
  sys:run()
  sys:wait_state(HANG, "running", 10)
  if shared then
    local tick = require("dca.core").every(0.01, function() end)  -- wakes the wait to read the note again
    sys:wait("hang's code to run (its node's crash note names it)", function() return note_of(HANG) == HANG end, 30)
    tick:cancel()
  end
end)

S.step("kill -SEGV from outside: the run ends ABORTED, and nobody is blamed for a crash in their code", function()
  sys:kill(HANG, "SEGV")
  local out = sys:wait_outcome(30)
  S.eq(out.type, "aborted")
  S.contains(out.reason, "SIGSEGV")
  if shared then
    S.eq(out.path, "main.work.alpha")
    S.ok(not out.reason:find("it crashed in", 1, true), "no culprit named: " .. out.reason)
  else
    S.eq(out.path, HANG)
  end
end)
return S.finish()
