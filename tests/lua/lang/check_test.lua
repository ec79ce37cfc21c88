-- dca.lang.check beyond the golden texts: registry modes, builtins, group ports, the paper systems.
local T = require "dca.testing"
local parser = require "dca.lang.parser"
local check = require "dca.lang.check"
local suite = T.suite("check")

local src, read = T.src, T.read
local sformat = string.format

local function errors(text, opts)
  local ast = assert(parser.parse(text, "t.dca"))
  local out = {}
  for i, e in ipairs(check.check(ast, opts)) do out[i] = e.path .. ": " .. e.msg end
  return out
end

local SYS = [[
process G(h) {
  host { h }
  instantiated_processes { s instof Sensor(h); f instof Filter(h, 0.5); }
  external_io { Out = f, Out; In = f, In; }
  internal_connections(s, l) { s, Out -> f, In; }
  internal_event_actions { s[l] , f }
}
process main() {
  instantiated_processes { g instof G("h1"); sink instof Sink("h2"); }
  internal_connections(g, l) { g, Out -> sink, In; }
  internal_event_actions { g[l] , sink }
}
]]

local TYPES = {
  Sensor = { inputs = {}, outputs = { { name = "Out" } }, params = {} },
  Filter = { inputs = { { name = "In" } }, outputs = { { name = "Out" } },
             params = { { name = "alpha", type = "number", required = true } } },
  Sink = { inputs = { { name = "In" } }, outputs = {}, params = {} },
}

suite:case("correct_system_has_no_errors_with_or_without_registry", function()
  T.eq(errors(SYS), {})
  T.eq(errors(SYS, { types = TYPES }), {})
  T.eq(errors(SYS, { manifest = function(t) return TYPES[t] end }), {})
end)

suite:case("without_registry_undefined_types_are_leaves", function()
  T.eq(errors([[process main() { instantiated_processes { a instof Whatever("h", 1, "x"); }
                                   internal_event_actions { a } }]]), {})
end)

suite:case("manifest_function_makes_unknown_types_errors", function()
  local e = errors([[process main() { instantiated_processes { a instof Sensr("h"); }
                                        internal_event_actions { a } }]],
                   { manifest = function(t) return TYPES[t] end, type_names = { "Sensor" } })
  T.eq(e, { "main.a: unknown process type 'Sensr' (did you mean 'Sensor'?)" })
end)

suite:case("builtin_timer_and_deadline", function()
  local text = [[process main() { instantiated_processes { t instof Timer("h", 30); d instof Deadline("h", 2.5); }
                                   internal_event_actions { t # d } }]]
  T.eq(errors(text, { types = {} }), {})
  T.eq(errors([[process main() { instantiated_processes { t instof Timer("h", "soon"); }
                                   internal_event_actions { t } }]], { types = {} }),
       { "main.t: parameter 'duration' of Timer is a number, got the string \"soon\"" })
end)

-- A numeral past the largest double reads as inf in Lua: a Deadline of 1e999 s aborted at once (the C++ side
-- now saturates finite long times to "never", host/timers.h); the check refuses it at its position.
suite:case("numbers_out_of_range_are_errors_at_their_position", function()
  local ast = assert(parser.parse([[process main() {
  instantiated_processes { t instof Timer("h", 1e999); d instof Deadline("h", -1e400); k instof Timer("h", 1e300); }
  internal_event_actions { t , d , k } }]], "t.dca"))
  local got = {}
  for _, e in ipairs(check.check(ast, { types = {} })) do got[#got + 1] = sformat("%d:%d %s", e.line, e.col, e.msg) end
  T.eq(got, { "2:48 number out of range (a number is at most about 1.8e308)",
              "2:79 number out of range (a number is at most about 1.8e308)" })
end)

suite:case("group_ports_follow_their_exports", function()
  -- the direction of an exported port is that of the inner port
  local bad = SYS:gsub("g, Out %-> sink, In;", "sink, In -> g, Out;")
  T.eq(errors(bad, { types = TYPES }), {
    "main.sink: 'In' is an input of sink (Sink): a connection goes from an output to an input",
    "main.g: 'Out' is an output of g (G): a connection goes from an output to an input" })
  -- without manifests only the export names are known
  local unknown = SYS:gsub("g, Out %-> sink, In;", "g, Nope -> sink, In;")
  T.eq(errors(unknown), { "main.g: no output 'Nope' on g (G); its external_io: Out, In" })
end)

suite:case("errors_come_in_file_order_with_paths", function()
  local e = errors([[
process main() {
  instantiated_processes { a instof T("h"); a instof T("h"); }
  internal_event_actions { b , a }
}]])
  T.eq(e, { "main.a: duplicate instance 'a' in process 'main' (first at line 2)",
            "main: unknown instance 'b' in internal_event_actions (instances: a)" })
end)

suite:case("paths_follow_the_first_instantiation", function()
  local ast = assert(parser.parse([[
process Leafy(h) { instantiated_processes { x instof T(h); } internal_event_actions { x ; y } }
process Mid(h) { instantiated_processes { l instof Leafy(h); } internal_event_actions { l } }
process main() { instantiated_processes { m instof Mid("h"); } internal_event_actions { m } }
]], "p.dca"))
  local e = check.check(ast)
  T.eq(#e, 1)
  T.eq(e[1].path, "main.m.l")
  T.eq(check.format(ast, e[1]),
       "p.dca:1:91: main.m.l: unknown instance 'y' in internal_event_actions (instances: x)\n" ..
       "process Leafy(h) { instantiated_processes { x instof T(h); } internal_event_actions { x ; y } }\n" ..
       string.rep(" ", 90) .. "^")
end)

suite:case("chosen_root", function()
  local ast = assert(parser.parse(SYS, "s.dca"))
  T.eq(#check.check(ast, { root = "G" }), 0)
  local e = check.check(ast, { root = "Nope" })
  T.eq(e[1].msg, "no process 'Nope' to run as the root")
end)

suite:case("paper_systems_pass", function()
  for _, name in ipairs({ "compliant_motion", "door_open", "tidy_up" }) do
    local ast = assert(parser.parse(read(src .. "/scripts/systems/" .. name .. ".dca"), name))
    local e = check.check(ast)
    T.eq(#e, 0, name .. ": " .. (e[1] and check.format(ast, e[1]) or ""))
  end
end)

suite:case("rt_section_errors_at_their_clauses", function()
  local ast, err = parser.parse([[process main() {
  rt { priority 120; cpu -1; priority 5; }
  instantiated_processes { t instof Timer("h", 1); }
  internal_event_actions { t } }]], "t.dca")
  T.ok(ast, err)
  local got = {}
  for _, e in ipairs(check.check(ast, { types = {} })) do got[#got + 1] = sformat("%d:%d %s", e.line, e.col, e.msg) end
  T.eq(got, { "2:17 rt priority must be 1..99 (SCHED_FIFO), got 120",
              "2:26 rt cpu must be a CPU number, 0..1023, got -1",
              "2:30 'priority' is given twice in rt (first at line 2)" })
  local _, perr = parser.parse("process main() { rt { period 5; } internal_event_actions { } }", "t.dca")
  T.ok(perr and perr:find("unknown rt clause 'period'", 1, true), perr)
  _, perr = parser.parse("process main() { rt { priority high; } internal_event_actions { } }", "t.dca")
  T.ok(perr and perr:find("expected a whole number after 'priority'", 1, true), perr)
end)

return suite:run(...)
