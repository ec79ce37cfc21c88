-- The configuration repository in a scenario: the system's defaults file seeds every host's replica before the
-- start, the controllers' config("key") parameters are read from it, a watch on one host sees a write made on
-- another, and a wrong key in a system file fails the start by name with nothing left running.
local S = require "dca.scenario"
local T = require "dca.testing"
local src = os.getenv("DCA_SOURCE_DIR") or "."
local sys = S.system(src .. "/scripts/systems/test_config.dca", { set = { ["test.wait"] = 0.2 } })

S.step("the defaults file and `set` are in every host's replica before the start", function()
  sys:up()
  S.eq(sys:config("h1"):get("test.threshold"), 1.0)
  S.eq(sys:config("h2"):get("test.threshold"), 1.0)
  S.eq(sys:config("h2"):get("test.wait"), 0.2, "set wins over the defaults file's 0.5")
end)

S.step("a watch on h1 sees a write made on h2", function()
  local seen = sys:config("h1"):watch("test")
  sys:config("h2"):set({ ["test.note"] = "from h2", ["test.level"] = 3 })
  local function got()
    local g = {}
    for _, ev in ipairs(seen) do g[ev.key] = ev.value end
    return g
  end
  sys:wait("both replicated changes on h1", function() return got()["test.level"] and got()["test.note"] end, 10)
  -- (every event the watch had, should a key be missing or another come in)
  S.eq(got(), { ["test.note"] = "from h2", ["test.level"] = 3 }, T.show(seen))
  S.eq(sys:config("h1"):get("test.note"), "from h2")
end)

S.step("the Timer waits the repository's test.wait and the Threshold gets its level", function()
  sys:run()
  sys:wait_state("main.wait", "done", 5)
  if sys.backend == "memory" then
    S.eq(sys:now(), 0.2, "the Timer's 0.2 s of simulated time")
    S.eq(sys:node("main.gate").args, { 1.0 })
  end
  sys:inject("main.gate", "done", 1.0)
  S.eq(sys:wait_outcome(10).type, "done")
end)

S.step("a misspelt key fails the start naming process, parameter and key; nothing is left", function()
  sys:stop()
  local f = assert(io.open(src .. "/scripts/systems/test_config.dca"))
  local text = f:read("a"):gsub('config%("test.wait"%)', 'config("test.wiat")')
  f:close()
  local bad = S.system(T.tmpfile(text), { config = src .. "/scripts/systems/test_config.config" })
  T.cleanup()
  local ok, err = bad:try_up(30)
  S.eq(ok, nil)
  S.ok(tostring(err):find("main.wait", 1, true), err)
  S.ok(tostring(err):find("parameter 1 'seconds' (config key 'test.wiat'): unknown key 'test.wiat'", 1, true), err)
  S.ok(bad:stop(), "nothing left running after the failed start")
end)
return S.finish()
