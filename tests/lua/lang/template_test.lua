-- Templates in the language (docs/supervision.md, "A fleet"): `name instances of Type(args) on { hosts };` parsed
-- with its positions, checked, and instantiated by dca.lang.model as one prepared instance per host (none started).
-- Errors are goldens (golden/syntax_template_*.dca, golden/check_template.dca).
local T = require "dca.testing"
local parser = require "dca.lang.parser"
local model = require "dca.lang.model"
local suite = T.suite("template")

local GOOD = [[
process Robot(h, period) {
  instantiated_processes { c instof Counter(h, period); }
  internal_event_actions { c }
}
process main(spare) {
  instantiated_processes {
    door instof Counter("base", 0.1);
    robots instances of Robot(0.5) on { "r1", "lab-2.example", spare };
    one instances of Timer(30) on "r9";
  }
  internal_event_actions { door }
}
]]

suite:case("a_template_parses_with_its_hosts_and_positions", function()
  local ast = assert(parser.parse(GOOD, "fleet.dca"))
  local main = ast.by_name.main
  T.eq(#main.instances, 1, "a template is no instance")
  T.eq(#main.templates, 2)
  local t = main.templates.robots
  T.eq({ t.name, t.type, t.line, t.col, t.type_line, t.type_col, t.on_line, t.on_col },
       { "robots", "Robot", 8, 5, 8, 25, 8, 36 })
  T.eq(t.args[1].value, 0.5)
  T.eq({ t.hosts[1].kind, t.hosts[1].value, t.hosts[3].kind, t.hosts[3].value, t.hosts[3].line, t.hosts[3].col },
       { "string", "r1", "param", "spare", 8, 64 })
  T.eq(#main.templates.one.hosts, 1, "one host without braces")
end)

suite:case("the_model_prepares_one_instance_per_host", function()
  local ast = assert(parser.parse(GOOD, "fleet.dca"))
  local tree, errs = model.build(ast, { args = { "spare-1" } })
  T.ok(tree, errs and errs[1] and errs[1].msg)
  T.eq(#tree.children, 1)
  local t = tree.templates.robots
  T.eq({ t.kind, t.path }, { "group", "main.robots" })
  T.eq(t.hosts, { "r1", "lab-2.example", "spare-1" })
  local names = {}
  for i, n in ipairs(t.instances) do names[i] = n.name end
  T.eq(names, { "robots_r1", "robots_lab_2_example", "robots_spare_1" })
  local r2 = t.instances["lab-2.example"]
  T.eq({ r2.path, r2.host, r2.children.c.host, r2.children.c.params }, { "main.robots_lab_2_example", "lab-2.example",
       "lab-2.example", { 0.5 } })
  T.eq(tree.templates.one.instances[1].args, { "r9", 30 }, "a leaf instance: its host, then the written arguments")
end)

suite:case("a_host_bound_to_a_bad_value_is_an_error_at_the_template", function()
  local ast = assert(parser.parse(GOOD, "fleet.dca"))
  local tree, errs = model.build(ast, { args = { "not a host" } })
  T.eq(tree, nil)
  T.contains(errs[1].msg, "the host of template robots of main is \"not a host\"")
end)

suite:case("the_summary_counts_templates_and_their_hosts", function()
  local ast = assert(parser.parse(GOOD, "fleet.dca"))
  local s = model.summary(assert(model.build(ast, { args = { "spare-1" } })))
  T.eq({ s.groups, s.instances, s.templates }, { 1, 1, 2 })
  T.eq(s.hosts, { "base", "lab-2.example", "r1", "r9", "spare-1" })
end)

suite:case("dca_graph_draws_a_template_as_one_dashed_box_below_its_group", function()
  local ast = assert(parser.parse(GOOD, "fleet.dca"))
  local dot = require("dca.lang.graph").dot(assert(model.build(ast, { args = { "spare-1" } })))
  T.contains(dot, '"main.robots[*]" [shape=box, style="dashed,rounded", label="robots : Robot, any number of '
    .. 'instances\\n@{ r1, lab-2.example, spare-1 }"];')
  T.contains(dot, '"main.door" -> "main.robots[*]" [style=invis];')
  T.ok(not dot:find("robots_r1", 1, true), "no prepared instance is drawn")
end)

return suite:run(...)
