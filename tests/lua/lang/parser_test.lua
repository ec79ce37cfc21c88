-- dca.lang.parser: the AST's shape and positions, comments, expressions mapped to file positions, and that
-- parse never raises. (Exact error texts are golden tests: golden_test.lua.)
local T = require "dca.testing"
local parser = require "dca.lang.parser"
local algebra = require "dca.algebra"
local suite = T.suite("parser")

local src, read = T.src, T.read

local CM = [[
process CompliantMotion(host1, host2) {
  host { host1 }
  instantiated_processes {
    forcedata instof ForceSensor(host1);
    compliant instof CompliantCtrl(host1);
    puma      instof Puma560(host2, "arm", -2.5, 7);
    hit       instof HitDetector(host1);
  }
  external_io { Force = forcedata, Out1; }
  internal_connections(forcedata, lbl1) {
    forcedata, Out1 -> compliant, In1;
    forcedata, Out1 -> hit, In1;
  }
  internal_connections(compliant, lbl1) { compliant, Out1 -> puma, In1; }
  internal_event_actions {
    // comments: // to end of line, and /* ... */
    hit # /* the drivers */ (forcedata[lbl1], compliant[lbl1],
      puma)
  }
}
process main() { instantiated_processes { m instof CompliantMotion("c1.example", "c2.example"); }
                 internal_event_actions { m } }
]]

suite:case("ast_shape_of_the_issue_example", function()
  local ast = assert(parser.parse(CM, "cm.dca"))
  T.eq(ast.file, "cm.dca")
  T.eq(#ast.processes, 2)
  local p = ast.by_name.CompliantMotion
  T.eq({ p.name, p.line, p.col }, { "CompliantMotion", 1, 1 })
  T.eq({ p.params[1].name, p.params[2].name, p.params[2].line, p.params[2].col }, { "host1", "host2", 1, 32 })
  T.eq({ p.host.kind, p.host.value, p.host.line, p.host.col }, { "param", "host1", 2, 10 })
  T.eq(#p.instances, 4)
  local puma = p.instances.puma
  T.ok(puma == p.instances[3], "instances by name and in order")
  T.eq({ puma.name, puma.type, puma.line, puma.col, puma.type_line, puma.type_col }, { "puma", "Puma560", 6, 5, 6, 22 })
  T.eq(#puma.args, 4)
  T.eq({ puma.args[1].kind, puma.args[1].value }, { "param", "host2" })
  T.eq({ puma.args[2].kind, puma.args[2].value, puma.args[2].col }, { "string", "arm", 37 })
  T.eq({ puma.args[3].kind, puma.args[3].value }, { "number", -2.5 })
  T.eq({ puma.args[4].kind, puma.args[4].value }, { "number", 7 })
  T.eq(math.type(puma.args[4].value), "integer")
  local x = p.external_io.Force
  T.ok(x == p.external_io[1])
  T.eq({ x.alias, x.instance, x.port, x.line, x.col }, { "Force", "forcedata", "Out1", 9, 17 })
  T.eq(#p.internal_connections, 2)
  local set = p.internal_connections[1]
  T.eq({ set.instance, set.label, set.line, set.col, #set.connections }, { "forcedata", "lbl1", 10, 3, 2 })
  local c = set.connections[2]
  T.eq({ c.from, c.out, c.to, c["in"], c.line, c.col }, { "forcedata", "Out1", "hit", "In1", 12, 5 })
  T.eq({ c.out_line, c.out_col, c.to_line, c.to_col, c.in_line, c.in_col }, { 12, 16, 12, 24, 12, 29 })
end)

suite:case("expression_text_tree_and_positions", function()
  local ast = assert(parser.parse(CM, "cm.dca"))
  local act = ast.by_name.CompliantMotion.actions
  T.ok(act.text:find("comments:", 1, true), "the text is the section's text, comments included")
  T.ok(act.expr, "parsed expression")
  T.eq(algebra.tostring(act.expr), "hit # (forcedata[lbl1], compliant[lbl1], puma)")
  T.eq({ act.line, act.col }, { 17, 5 }, "the expression starts at its first token")
  T.eq({ act.text_line, act.text_col, act.section_line, act.section_col }, { 15, 27, 15, 3 })
  T.eq(#act.expr.text, #act.text, "comments blanked, length kept")
  T.ok(not act.expr.text:find("comments", 1, true), "no comment text in expr.text")
  local leaves = act.expr.leaves
  T.eq({ leaves[1].name, leaves[1].line, leaves[1].col }, { "hit", 17, 5 })
  T.eq({ leaves[2].name, leaves[2].label, leaves[2].line, leaves[2].col }, { "forcedata", "lbl1", 17, 30 })
  T.eq({ leaves[4].name, leaves[4].line, leaves[4].col }, { "puma", 18, 7 })
  -- the expression object runs as it is
  local started = {}
  local run = algebra.new(act.expr, { start = function(n) started[#started + 1] = n end })
  run:start()
  T.eq(started, { "hit", "forcedata", "compliant", "puma" })
end)

suite:case("expression_errors_are_kept_for_check", function()
  local ast = assert(parser.parse("process main() {\n  instantiated_processes { a instof T(\"h\"); }\n" ..
                                  "  internal_event_actions {\n    a ;\n  }\n}\n", "e.dca"))
  local act = ast.by_name.main.actions
  T.eq(act.expr, nil)
  T.eq({ act.error.line, act.error.col }, { 4, 7 })
  T.contains(act.error.msg, "trailing operator")
end)

suite:case("sections_in_any_order_and_empty_ones", function()
  local ast = assert(parser.parse([[
process P() {
  internal_event_actions { a }
  internal_connections(a, l) { }
  external_io { }
  instantiated_processes { a instof T("h"); }
  host { "somewhere" }
}]], "p.dca"))
  local p = ast.by_name.P
  T.eq({ p.host.kind, p.host.value }, { "string", "somewhere" })
  T.eq(#p.instances, 1)
  T.eq(#p.internal_connections[1].connections, 0)
  T.eq(#p.duplicate_sections, 0)
  T.ok(parser.parse("", "empty.dca"), "an empty file is a file with no processes")
  T.eq(#parser.parse("// only a comment\n/* and another */", "c.dca").processes, 0)
end)

suite:case("string_escapes", function()
  local ast = assert(parser.parse([[process P() { instantiated_processes { a instof T("h", "q\"b\\s\n\t"); } }]]))
  T.eq(ast.by_name.P.instances.a.args[2].value, "q\"b\\s\n\t")
end)

suite:case("keywords_start_sections_only_before_a_brace", function()
  local ast, err = parser.parse("process P() { instantiated_processes { a instof T(\"h\"); host { h } }", "k.dca")
  T.eq(ast, nil)
  T.contains(err, "k.dca:1:57: missing '}' to close 'instantiated_processes' (opened at line 1) before 'host'")
  ast = assert(parser.parse("process P(host) { host { host } instantiated_processes { host instof T(host); " ..
                            "process instof T(host); processor instof T(\"h\"); } }"))
  local p = ast.by_name.P
  T.eq({ p.params[1].name, p.host.value, p.instances[1].name, p.instances[2].name, p.instances[3].name },
       { "host", "host", "host", "process", "processor" })
end)

suite:case("error_format_has_file_line_col_source_and_caret", function()
  local _, err = parser.parse("process P() {\n\thost (h)\n}\n", "tab.dca")
  T.eq(err, "tab.dca:2:7: 'host' takes braces, not parentheses: write 'host { h }'\n\thost (h)\n\t     ^")
  _, err = parser.parse("process P() {\r\n  host (h)\r\n}\r\n", "crlf.dca")
  T.eq(err, "crlf.dca:2:8: 'host' takes braces, not parentheses: write 'host { h }'\n  host (h)\n       ^")
end)

suite:case("parse_never_raises", function()
  local inputs = { nil, 42, {}, "\0", "process", "process P", "process P(", "process P(a,", "process P() {",
                   "process P() { host {", "process P() { host { \"x", "process P() { instantiated_processes { a instof",
                   "process P() { internal_event_actions { ((((( } }", "/*", "//", "\"", string.rep("{", 10000),
                   "process P() { internal_event_actions { " .. string.rep("(", 3000) .. "a" .. string.rep(")", 3000) .. " } }",
                   string.rep("process P() { }\n", 2000), "\255\254\253" }
  for i = 1, #inputs + 1 do
    local ok, ast, err = pcall(parser.parse, inputs[i], "x.dca")
    T.ok(ok, "raised: " .. tostring(ast))
    T.ok(ast or type(err) == "string", "ast or message")
  end
end)

suite:case("paper_systems_parse", function()
  for _, name in ipairs({ "compliant_motion", "door_open", "tidy_up" }) do
    local path = src .. "/scripts/systems/" .. name .. ".dca"
    local ast, err = parser.parse(read(path), path)
    T.ok(ast, err)
    T.ok(ast.by_name.main, "main in " .. name)
  end
  local ast = assert(parser.parse(read(src .. "/worlds/door/systems/door_open.dca"), "door_open.dca"))
  T.eq(algebra.tostring(ast.by_name.DoorOpenSystem.actions.expr),
       "motionctrl # ((visualserv[lbl1], camera) # distdetect ; (opengrip, approach[lbl1]) # hit ; closegrip ; " ..
       "presshandle[lbl1] # (pressft, pressjoints) ; dooropen[lbl1])")
end)

suite:case("supervision_section_and_standby_hosts", function()
  local ast = assert(parser.parse([[
process Vision(h1, h1b) {
  host { h1, h1b, "h1c" }
  supervision {
    strategy rest_for_one;
    intensity 3 in 500 ms;
    restart on crash, aborted;
    standby cam on "h2b", h1b;
  }
  instantiated_processes { cam instof Timer(h1, 1); }
  internal_event_actions { cam }
}
]], "v.dca"))
  local p = ast.by_name.Vision
  T.eq({ p.host.value, #p.standby_hosts, p.standby_hosts[1].value, p.standby_hosts[2].kind },
       { "h1", 2, "h1b", "string" })
  T.eq({ p.standby_hosts[2].line, p.standby_hosts[2].col }, { 2, 19 })
  local cl = p.supervision.clauses
  T.eq({ p.supervision.line, p.supervision.col, #cl }, { 3, 3, 4 })
  T.eq({ cl[1].kw, cl[1].name, cl[1].name_line, cl[1].name_col }, { "strategy", "rest_for_one", 4, 14 })
  T.eq({ cl[2].kw, cl[2].count, cl[2].within, cl[2].unit, cl[2].unit_col }, { "intensity", 3, 500, "ms", 24 })
  T.eq({ cl[3].kw, cl[3].kinds[1].name, cl[3].kinds[2].name, cl[3].kinds[2].col }, { "restart", "crash", "aborted", 23 })
  T.eq({ cl[4].kw, cl[4].instance, cl[4].instance_col, cl[4].hosts[1].value, cl[4].hosts[2].value },
       { "standby", "cam", 13, "h2b", "h1b" })
  -- the unit may follow the period at once
  local tight = assert(parser.parse("process m(h) { supervision { intensity 2 in 10s; } }", "t.dca"))
  local ti = tight.by_name.m.supervision.clauses[1]
  T.eq({ ti.count, ti.within, ti.unit, ti.unit_col }, { 2, 10, "s", 47 })
  -- fence: its time, its unit and its margin, each may be left out
  local fenced = assert(parser.parse("process m(h) { supervision { fence 1.5; } } process n(h) { supervision { "
                                     .. "fence 1500 ms margin 0.5 s; } }", "f.dca"))
  local f1, f2 = fenced.by_name.m.supervision.clauses[1], fenced.by_name.n.supervision.clauses[1]
  T.eq({ f1.kw, f1.within, f1.unit, f1.margin, f1.within_col }, { "fence", 1.5, nil, nil, 36 })
  T.eq({ f2.within, f2.unit, f2.margin, f2.margin_unit, f2.margin_col }, { 1500, "ms", 0.5, "s", 95 })
  -- without the section: no policy, no standby hosts
  local plain = assert(parser.parse("process main(h) { host { h } internal_event_actions { } }", "p.dca"))
  T.eq({ plain.by_name.main.supervision, #plain.by_name.main.standby_hosts }, { nil, 0 })
end)

return suite:run(...)
