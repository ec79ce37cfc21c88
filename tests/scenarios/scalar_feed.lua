-- The built-ins' vectorx ports meet scalar ports: a Constant of one value, a Sum and a Gain feed scalar inputs
-- and a Counter feeds the Sum (scripts/systems/test_scalar_feed.dca). The links are made and the run ends DONE.
local S = require "dca.scenario"
local src = os.getenv("DCA_SOURCE_DIR") or "."
local sys = S.system(src .. "/scripts/systems/test_scalar_feed.dca")

S.step("the tree comes up: every link into a scalar input is made", function() sys:up() end)

S.step("2 * (-2.5 + ramp) crosses 0 at 1 and ends the task DONE 1", function()
  sys:run()
  local out = sys:wait_outcome(10)
  S.eq(out.type, "done")
  S.eq(out.value, 1)
end)

S.step("the Constant's value reached the scalar input it feeds directly", function()
  S.eq(sys:read("main.level", "In"), -2.5)
end)

S.step("stop leaves no process behind", function() S.ok(sys:stop(), "all stopped") end)
return S.finish()
