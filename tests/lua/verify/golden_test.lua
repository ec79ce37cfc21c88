-- Golden tests of `dca check --verify`: the report for each tests/lua/verify/golden/NAME.dca (one finding kind
-- or the property patterns each, with traces) must equal NAME.out exactly; the paper's three systems
-- (scripts/systems/) and the door written as in the paper (systems/door_paper.dca) likewise, against
-- golden/paper_NAME.out. DCA_GOLDEN_UPDATE=1 rewrites the .out files (review the diff!).
local T = require "dca.testing"
local load = require "dca.load"
local verify = require "dca.verify"
local report = require "dca.verify.report"
local suite = T.suite("golden")

local here = T.here()
local src = T.src

-- The report for the file at path, named `name` in it.
local function output(path, name, traces)
  local ast, tree = load.text(T.read(path), name, {})
  if not ast then return tree .. "\n" end
  local result, errs = verify.system(tree, { ast = ast })
  if not result then
    local out = {}
    for _, e in ipairs(errs) do out[#out + 1] = string.format("%s:%d:%d: %s", name, e.line, e.col, e.msg) end
    return table.concat(out, "\n") .. "\n"
  end
  return (report.text(result, { file = name, traces = traces }))
end

local function golden(case, path, name, out_path, traces)
  suite:case(case, function()
    T.golden(out_path, output(path, name, traces), name)
  end)
end

local kinds = { "stuck", "never_ends", "dead", "conflict", "cross_conflict", "cross_conflict_deep", "props", "loop",
                "timers", "writers_par", "writers_groups", "writers_label", "writers_restart", "writers_dead",
                "writers_claims", "timers_steps", "ends_params" }
for _, k in ipairs(kinds) do
  golden(k, here .. "/golden/" .. k .. ".dca", k .. ".dca", here .. "/golden/" .. k .. ".out", true)
end
for _, s in ipairs({ "door_open", "tidy_up", "compliant_motion" }) do
  golden("paper_" .. s, src .. "/scripts/systems/" .. s .. ".dca", s .. ".dca",
         here .. "/golden/paper_" .. s .. ".out", false)
end
golden("paper_door_as_written_never_ends_done", here .. "/systems/door_paper.dca", "door_paper.dca",
       here .. "/golden/paper_door_paper.out", false)
golden("door_properties", here .. "/systems/door_props.dca", "door_props.dca",
       here .. "/golden/door_props.out", false)

suite:case("cross_conflict_needs_both_sets_active_together", function()
  -- the same connections, but main runs inner to its end before outer starts: no conflict
  local text = T.read(here .. "/golden/cross_conflict.dca")
  local seq, n = text:gsub("stop # %(outer%[lbl1%], inner%)", "inner ; (stop # outer[lbl1])")
  T.eq(n, 1)
  local ast, tree = load.text(seq, "cross_seq.dca", {})
  T.ok(ast, tree)
  local result = assert(verify.system(tree, { ast = ast }))
  for _, r in ipairs(result.groups) do T.eq(#r.conflicts, 0, r.path) end
  T.ok(not report.text(result):find("connection sets", 1, true))
end)

return suite:run(...)
