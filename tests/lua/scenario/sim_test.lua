-- Simulated-time systems in scenarios and `dca run --sim`: the options that reach the world, and the
-- refusals that name what is wrong (the runs themselves are tests/scenarios/door_*.lua, scenario_real.door_*).
local T = require "dca.testing"
local suite = T.suite("scenario_sim")

local dca = os.getenv("DCA_EXE") or "dca"
local src = os.getenv("DCA_SOURCE_DIR") or "."

local function tmpfile(text)
  local path = os.tmpname() .. ".lua"
  local f = assert(io.open(path, "w"))
  f:write(text)
  f:close()
  return path
end

suite:case("world_argv_carries_seed_width_and_the_jam", function()
  local sim = require "dca.clients.world"
  local argv = sim.argv({ daemon = "127.0.0.1:1", host = "h", world = "door", seed = 3, door_width = 0.9, jammed = true })
  T.eq(argv, { "dca", "sim", "--serve", "--daemon", "127.0.0.1:1", "--host", "h", "--world", "door",
               "--seed", "3", "--door-width", "0.9", "--jammed" })
  argv = sim.argv({ daemon = "127.0.0.1:1", host = "h" })
  for _, a in ipairs(argv) do T.ok(a ~= "--jammed", "no --jammed unless asked") end
end)

suite:case("run_jammed_needs_sim", function()
  local out, rc = T.sh(dca .. " run " .. src .. "/scripts/systems/door_open.dca --jammed")
  T.eq(rc, 2, "exit code")
  T.contains(out, "--jammed go with --sim WORLD")
end)

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
