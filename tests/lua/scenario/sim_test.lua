-- Simulated-time systems in scenarios: the refusals that name what is wrong (the runs themselves are
-- worlds/door/tests/scenarios/door_*.lua, scenario_real.door_*; the world's argv is tests/lua/clients/world_test.lua).
local T = require "dca.testing"
local suite = T.suite("scenario_sim")

local src = os.getenv("DCA_SOURCE_DIR") or "."

-- Runs a scenario of one system (FILE under scripts/systems, its S.system options, the scenario's first line)
-- with `dca scenario ARGS`: it must fail (exit 1) saying `why`. --> its output
local function refused(system, options, first, args, why)
  local path = T.tmpfile('local S = require "dca.scenario"\n' .. first .. 'local sys = S.system("' .. src
    .. "/scripts/systems/" .. system .. '"' .. options .. ')\nreturn S.finish()\n', ".lua")
  local out = T.dca("scenario " .. args .. path, 1, why)
  os.remove(path)
  return out
end

suite:case("a_real_only_scenario_refuses_the_memory_backend", function()
  local out = refused("test_crash.dca", "", 'S.backends = { "real" }\n', "--backend memory ",
    "runs on the backend(s) real only")
  T.ok(not out:find("0 failed"), "no summary of a pass: " .. out)
end)

suite:case("a_world_needs_the_real_backend", function()
  refused("door_open.dca", ', { sim = "door" }', "", "", "needs --backend real")
end)

return suite:run(...)
