-- The counter-example of `dca check --verify` on the door as the paper writes it (motionctrl , (...)), replayed:
-- the scenario dca.verify.scenario writes for it is run here as it is (in memory with the leaves' behaviours
-- off; with --backend real by the real processes in the simulated world). The door opens and main never ends:
-- ',' waits for ever on the motion controller.
local dca_load = require "dca.load"
local verify = require "dca.verify"
local scenario = require "dca.verify.scenario"
local file = (os.getenv("DCA_SOURCE_DIR") or ".") .. "/tests/lua/verify/systems/door_paper.dca"
local ast, tree = dca_load.file(file)
if not ast then error(tree, 0) end
local result = assert(verify.system(tree, { ast = ast }))
local text = assert(scenario.text(result, file, "main"), "a counter-example")
assert(text:find("main can end done is violated: main.dooropensyst gets stuck", 1, true), text)
return assert(load(text, "=door_paper counter-example"))()
