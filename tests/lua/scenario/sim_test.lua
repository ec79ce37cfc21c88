-- Simulated-time systems in scenarios: the refusals that name what is wrong (the runs themselves are
-- tests/scenarios/door_*.lua, scenario_real.door_*; the world's argv is tests/lua/clients/world_test.lua).
local T = require "dca.testing"
local suite = T.suite("scenario_sim")

local dca = os.getenv("DCA_EXE") or "dca"
local src = os.getenv("DCA_SOURCE_DIR") or "."

local function tmpfile(text) return T.tmpfile(text, ".lua") end

suite:case("a_real_only_scenario_refuses_the_memory_backend", function()
  local path = tmpfile('local S = require "dca.scenario"\nS.backends = { "real" }\n'
    .. 'local sys = S.system("' .. src .. '/scripts/systems/test_crash.dca")\nreturn S.finish()\n')
  local out, rc = T.sh(dca .. " scenario --backend memory " .. path)
  os.remove(path)
  T.eq(rc, 1, "exit code")
  T.contains(out, "runs on the backend(s) real only")
  T.ok(not out:find("0 failed"), "no summary of a pass: " .. out)
end)

suite:case("a_world_needs_the_real_backend", function()
  local path = tmpfile('local S = require "dca.scenario"\n'
    .. 'local sys = S.system("' .. src .. '/scripts/systems/door_open.dca", { sim = "door" })\nreturn S.finish()\n')
  local out, rc = T.sh(dca .. " scenario " .. path)
  os.remove(path)
  T.eq(rc, 1, "exit code")
  T.contains(out, "needs --backend real")
end)

return suite:run(...)
