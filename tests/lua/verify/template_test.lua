-- The verifier and templates (dca.verify.template; docs/verify.md, "A fleet"): a template's type is explored once,
-- whatever number of instances; the group's own exploration is the same with or without its templates (instances
-- are independent of the expression); an instance reaches the group's outcome only as an escalation of its
-- policy (a fault reason), none without a policy or with --no-faults.
local T = require "dca.testing"
local parser = require "dca.lang.parser"
local model = require "dca.lang.model"
local verify = require "dca.verify"
local report = require "dca.verify.report"
local suite = T.suite("verify_template")

local SYSTEM = [[
process Light(h, period) {
  instantiated_processes { c instof Counter(h, period); t instof Timer(h, 5); }
  internal_event_actions { c # t }
}
process Fleet(h) {
  host { h }
  SUPERVISION
  instantiated_processes {
    door instof Timer(h, 10);
    TEMPLATES
  }
  internal_event_actions { door }
}
process main() {
  instantiated_processes { fleet instof Fleet("base"); }
  internal_event_actions { fleet }
}
]]

local POLICY = "supervision { strategy one_for_one; intensity 2 in 10 s; restart on crash, lost; }"
local TEMPLATES = 'lights instances of Light(0.5) on { "r1", "r2", "r3" }; more instances of Light(1) on "r4";' ..
                  ' timers instances of Timer(5) on { "r1", "r2" };'

local function verified(policy, templates, faults)
  local text = SYSTEM:gsub("SUPERVISION", policy):gsub("TEMPLATES", templates)
  local ast = assert(parser.parse(text, "fleet.dca"))
  local tree, errs = model.build(ast, {})
  assert(tree, errs and errs[1] and errs[1].msg)
  local res = assert(verify.system(tree, { faults = faults ~= false, ast = ast }))
  local by = {}
  for _, r in ipairs(res.groups) do by[r.type] = r end
  return res, by
end

local function ends(r, fault)
  local out = {}
  for _, d in ipairs(r.done) do out[#out + 1] = "done " .. d.value end
  for _, a in ipairs(r.aborted) do if fault or not a.fault then out[#out + 1] = "aborted " .. a.reason end end
  return out
end

suite:case("a_template_type_is_explored_once_for_any_number_of_instances", function()
  local res, by = verified(POLICY, TEMPLATES)
  T.eq(#res.groups, 3, "Light once (two templates of it, four hosts), Fleet, main")
  T.eq(by.Light.path, "main.fleet.lights_r1")
  T.eq(#by.Fleet.templates, 3)
  T.eq(by.Fleet.templates[1].instance, by.Light, "the instance's verdicts are the type's")
  T.eq(by.Fleet.templates[3].instance, nil, "a leaf template: its type's manifest")
  local text = report.text(res)
  T.contains(text, "  template  lights: any number of instances on { r1, r2, r3 }, each verified once as "
    .. "main.fleet.lights_r1 (process Light), independent of the expression")
  T.contains(text, "their faults are restarts (one_for_one, 2 in 10 s); past that the group ends ABORTED by a fault")
end)

suite:case("the_group_exploration_is_the_same_with_or_without_its_templates", function()
  local _, with = verified(POLICY, TEMPLATES)
  local _, without = verified(POLICY, "")
  T.eq(ends(with.Fleet), ends(without.Fleet), "the same ends but by a fault")
  T.eq({ with.Fleet.states, with.Fleet.transitions }, { without.Fleet.states, without.Fleet.transitions })
  T.eq(ends(with.main), ends(without.main))
end)

suite:case("instances_reach_the_outcome_only_by_an_escalation_of_the_policy", function()
  local _, by = verified(POLICY, TEMPLATES)
  local escalations = {}
  for _, a in ipairs(by.Fleet.aborted) do
    if a.reason:find("escalated: an instance of", 1, true) then escalations[#escalations + 1] = a.reason end
  end
  T.eq(escalations, { "fleet escalated: an instance of lights crashed or lost its host past the restart intensity",
                      "fleet escalated: an instance of more crashed or lost its host past the restart intensity",
                      "fleet escalated: an instance of timers crashed or lost its host past the restart intensity" })
  -- the parent sees it among the fleet's faults
  local seen = false
  for _, a in ipairs(by.main.aborted) do seen = seen or a.reason:find("escalated: an instance of lights", 1, true) ~= nil end
  T.ok(seen, "main sees the escalation as a fault of fleet")
  -- without a policy, or without faults: none
  local _, nopol = verified("", TEMPLATES)
  T.eq(ends(nopol.Fleet, true), ends(verified("", "") and select(2, verified("", "")).Fleet, true))
  T.contains(report.text((verified("", TEMPLATES))), "an instance's end or fault ends that instance only")
  local _, nofault = verified(POLICY, TEMPLATES, false)
  T.eq(ends(nofault.Fleet, true), { "done door" })
end)

return suite:run(...)
