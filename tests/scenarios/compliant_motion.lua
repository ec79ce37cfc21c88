-- The compliant motion system of the paper with test controllers: the Threshold (hit) preempts the group.
local S = require "dca.scenario"
local src = os.getenv("DCA_SOURCE_DIR") or "."
local sys = S.system(src .. "/scripts/systems/test_compliant_motion.dca")

S.step("the tree comes up: every process started inactive and connected", function()
  sys:up()
  S.eq(#sys:alive(), 5, "one supervisor and four nodes")
  if sys.backend == "memory" then S.eq(#sys:node("main.motion.forcedata").conns, 1) end
  S.eq(sys:commands(" run$"), {}, "nothing runs before 'run'")
end)

S.step("the hit fires at force 20 and ends the expression DONE with its value", function()
  sys:run()
  local out = sys:wait_outcome(5)
  S.eq(out.type, "done")
  S.eq(out.value, 20)
end)

S.step("puma, compliant and forcedata were stopped in LIFO order, their sets deactivated", function()
  local stops = sys:commands(" stop$")
  S.eq(stops, { "main.motion.puma stop", "main.motion.compliant stop", "main.motion.forcedata stop" })
  if sys.backend == "memory" then S.eq(next(sys:node("main.motion.forcedata").active), nil) end
  local out = sys:read("main.motion.puma", "Out")
  if type(out) == "table" then out = out[1] end
  S.eq(out, 0.5, "the compliant command reached the arm")
end)

S.step("stop leaves no process behind", function() S.ok(sys:stop(), "all stopped") end)
return S.finish()
