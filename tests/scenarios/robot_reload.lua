-- The URDF world in a scenario (real backend, the mock UR10): the system is checked against the world it runs
-- with, and so is a reload of its file: against the UR10's joint ports (docs/robots.md), not the door's signals.
local S = require "dca.scenario"
S.backends = { "real" }
local src = os.getenv("DCA_SOURCE_DIR") or "."
local sys = S.system(src .. "/worlds/ur10/ur10_setpoint.dca", { sim = "mock:" .. src .. "/worlds/ur10/ur10.urdf" })

S.step("the tree comes up with the mock UR10", function()
  sys:up()
end)

S.step("a reload of the file is checked against the UR10's ports: nothing changed", function()
  local lines, err = sys:reload()
  S.eq(err, nil)
  S.eq(lines, {})
end)

S.step("the run ends DONE at the wrist's setpoint", function()
  sys:run()
  local out = sys:wait_outcome(60)
  S.eq(out.type, "done")
end)

return S.finish()
