-- Counter-examples replay: `dca check --verify --emit-scenario` writes a scenario that `dca scenario` runs in
-- memory, and running it shows the same violation (its last step checks it and passes).
local T = require "dca.testing"
local load = require "dca.load"
local verify = require "dca.verify"
local scenario = require "dca.verify.scenario"
local suite = T.suite("scenario")

local here = T.here()
local function abs(p) return (p:sub(1, 1) == "/") and p or (os.getenv("PWD") .. "/" .. p) end

-- Writes every counter-example of the file as a scenario and runs each: all pass, each shows its violation.
local function replay_all(file, want)
  local ast, tree = load.file(file)
  T.ok(ast, tree)
  local result = assert(verify.system(tree, { ast = ast }))
  local texts = {}
  for n = 1, #scenario.all(result) do
    local text, what = scenario.text(result, file, "main", n)
    local path = T.tmpfile(text, ".lua")
    local out = T.dca("scenario " .. path, 0, "the violation: " .. what, "0 failed")
    os.remove(path)
    texts[#texts + 1] = what
    T.ok(out)
  end
  T.eq(texts, want)
end

suite:case("the_paper_door_replays_stuck_after_the_door_is_open", function()
  local file = abs(here .. "/systems/door_paper.dca")
  local out_file = T.tmpname(".lua")
  T.dca("check " .. file .. " --verify --emit-scenario " .. out_file, 1, "VIOLATED  main can end done",
        "the counter-example: main can end done is violated: main.dooropensyst gets stuck")
  T.dca("scenario " .. out_file, 0, "main.dooropensyst.dooropen.model done",
        "the violation: main can end done is violated: main.dooropensyst gets stuck", "0 failed")
  os.remove(out_file)
end)

suite:case("every_counter_example_of_the_patterns_replays", function()
  replay_all(abs(here .. "/golden/props.dca"), {
    "c never starts before t is done", "c always ends before b starts", "a runs while b runs",
    "never (drive and c running)", "main cannot end aborted" })
end)

suite:case("the_door_properties_and_the_stuck_and_conflict_kinds_replay", function()
  replay_all(abs(here .. "/systems/door_props.dca"), { "distdetect never starts before camera is done",
    "never (visualserv and camera running)" })
  replay_all(abs(here .. "/golden/stuck.dca"), { "main gets stuck waiting on laser" })
  replay_all(abs(here .. "/golden/conflict.dca"), { "main.gain.In is fed by main.one.Out and main.two.Out" })
end)

suite:case("a_conflict_across_groups_replays", function()
  -- the lead-in runs main's trace, then the trace inside main.inner; the last step sees both owners running
  replay_all(abs(here .. "/golden/cross_conflict.dca"),
             { "main.inner.gain.In is fed by main.outer.Out and main.inner.src.Out" })
  replay_all(abs(here .. "/golden/cross_conflict_deep.dca"),
             { "main.mid.in2.gain.In is fed by main.outer.Out and main.mid.in2.src.Out" })
end)

return suite:run(...)
