-- The verify { } section: its property patterns, and labelled errors at file:line:col for what is not one.
local T = require "dca.testing"
local props = require "dca.verify.props"
local suite = T.suite("props")

suite:case("every_pattern_parses", function()
  local list, errs = props.parse([[
    closegrip never starts before hit is done;
    presshandle always ends before dooropen starts;
    motionctrl runs while any step runs; motionctrl runs while approach runs;
    main can end done; main can end aborted; main can end; main cannot end aborted;
    never (approach and presshandle running); never (a and b and c running);
  ]], 1)
  T.eq(errs, {})
  local kinds = {}
  for i, p in ipairs(list) do kinds[i] = p.kind .. ":" .. p.text end
  T.eq(kinds, { "starts_after_done:closegrip never starts before hit is done",
    "ends_before_start:presshandle always ends before dooropen starts", "runs_while:motionctrl runs while any step runs",
    "runs_while:motionctrl runs while approach runs", "can_end:main can end done", "can_end:main can end aborted",
    "can_end:main can end", "can_end:main cannot end aborted", "exclusive:never (approach and presshandle running)",
    "exclusive:never (a and b and c running)" })
  T.eq(list[8].negated, true)
  T.eq(list[8].how, "aborted")
end)

-- `dca check --verify` on a system whose verify section is `body`: exit code 1 and each fragment; a plain
-- `dca check` reports the same errors with the file's others (no "ok" line).
local function bad(body, ...)
  local file = T.tmpfile("process main() {\n  instantiated_processes {\n    a instof Threshold(\"h\", 1);\n" ..
    "    b instof Timer(\"h\", 1);\n  }\n  internal_event_actions { a ; b }\n  verify {\n" .. body .. "\n  }\n}\n")
  T.dca("check " .. file .. " --verify", 1, ...)
  local out = T.dca("check " .. file, 1, ...)
  T.ok(out:match(" errors?\n$") and not out:find(": ok:", 1, true), "plain check: errors, no ok line: " .. out)
  os.remove(file)
end

suite:case("errors_name_the_file_line_and_column", function()
  bad("    a sometimes starts;", ":8:7: main: unknown property 'a sometimes ...' (the properties are: ",
      "    a sometimes starts;\n      ^")
  bad("    a never starts before b is done", ":8:36: main: expected ';' at the end of the property")
  bad("    a never starts after b;", ":8:20: main: expected 'before' after 'starts', found 'after'")
  bad("    x never starts before b is done;", ":8:5: main: no instance 'x' in process 'main'")
  bad("    never (a running);", ":8:12: main: 'never (...)' names at least two instances joined by 'and'")
  bad("    a & b;", ":8:7: main: unexpected '&' in a property")
  bad("    ;", "empty property before ';'")
end)

suite:case("every_error_of_a_section_comes_at_once", function()
  bad("    a sometimes;\n    y runs while a runs;", ":8:7: main: unknown property", ":9:5: main: no instance 'y'",
      "2 errors")
end)

suite:case("a_violated_property_exits_1_and_one_that_holds_0", function()
  local file = T.tmpfile("process main() {\n  instantiated_processes {\n    a instof Threshold(\"h\", 1);\n" ..
    "    b instof Timer(\"h\", 1);\n  }\n  internal_event_actions { a ; b }\n  verify { b never starts before a is done; }\n}\n")
  T.dca("check " .. file .. " --verify", 0, "holds     b never starts before a is done", "0 violated properties")
  T.write(file, (T.read(file):gsub("b never starts before a is done", "a never starts before b is done")))
  T.dca("check " .. file .. " --verify", 1, "VIOLATED  a never starts before b is done", "counter-example:",
        "start a")
  T.dca("check " .. file .. " --verify --promela", 0, "init {", "mark = 1")
  T.dca("check " .. file .. " --verify --no-faults", 1, "faults off (--no-faults)")
  T.dca("check " .. file .. " --verify --max-states 1", 1, "PARTIAL exploration stopped at the state limit")
  T.write(file, (T.read(file):gsub("process main%(%)", "process task()")))
  T.dca("check " .. file .. " --verify", 1, "--verify explores from a root process: none is named 'main'")
  T.dca("check " .. file .. " --verify --root task", 1, "VIOLATED  a never starts before b is done")
  os.remove(file)
end)

suite:case("a_supervision_section_is_checked_and_ignored_by_the_verifier", function()
  -- the verifier explores the algebra with every fault possible; a restart policy only takes some faults away,
  -- so its verdicts stay sound (ARCHITECTURE.md, "Supervision policies")
  local file = T.tmpfile("process main() {\n  host { \"h\", \"h2\" }\n  supervision { strategy one_for_all; " ..
    "intensity 2 in 10 s; standby a on \"h3\"; }\n  instantiated_processes {\n    a instof Threshold(\"h\", 1);\n" ..
    "    b instof Timer(\"h\", 1);\n  }\n  internal_event_actions { a ; b }\n" ..
    "  verify { b never starts before a is done; }\n}\n")
  T.dca("check " .. file .. " --verify", 0, "holds     b never starts before a is done")
  T.dca("check " .. file, 0)
  T.dca("graph " .. file, 0, "one_for_all, 2 in 10 s, on crash, lost")
  os.remove(file)
end)

return suite:run(...)
