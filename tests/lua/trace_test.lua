-- dca.trace and `dca trace diff`: the first divergence of two traces, said with both sides; what is no trace
-- (a folder, an unparsable line) is said as such, never a Lua traceback or "(end of trace)".
local T = require "dca.testing"
local trace = require "dca.trace"
local suite = T.suite("trace")

local function file(text) return T.tmpfile(text, ".trace") end

suite:case("identical_traces_have_no_divergence_and_the_first_one_is_named", function()
  local a = file("1 D main.x.Out n=1 digest=1 value=1\n2 E main.x events=1\n")
  local b = file("1 D main.x.Out n=1 digest=1 value=1\n2 E main.x events=1\n")
  T.eq(trace.diff(a, b), nil)
  local c = file("1 D main.x.Out n=1 digest=1 value=1\n2 E main.x events=2\n")
  T.contains(trace.diff(a, c), "first divergence at line 2, tick 0.000000002 s (2 ns), process main.x:")
  T.cleanup()
end)

suite:case("a_shorter_trace_ends_and_an_unparsable_line_is_said_as_such", function()
  local full = file("1 D main.x.Out n=1\n2 D main.x.Out n=2\n")
  local short = file("1 D main.x.Out n=1\n")
  local garbled = file("1 D main.x.Out n=1\ngarbage here\n")
  local d = trace.diff(short, full)
  T.contains(d, "process main.x.Out:")
  T.contains(d, short .. ": (end of trace)")
  d = trace.diff(garbled, full)
  T.contains(d, garbled .. ": (not a trace line) garbage here")
  T.ok(not d:find("(end of trace)", 1, true), d)
  T.cleanup()
end)

suite:case("a_last_line_without_its_newline_is_still_a_line", function()
  local a = file("1 D main.x.Out n=1\n2 E main.x events=1")
  local b = file("1 D main.x.Out n=1\n2 E main.x events=1\n")
  T.eq(trace.diff(a, b), nil)
  local c = file("1 D main.x.Out n=1\n2 E main.x events=2")
  T.contains(trace.diff(a, c), "first divergence at line 2")
  T.cleanup()
end)

suite:case("a_folder_is_an_error_with_its_reason_not_a_traceback", function()
  local dir = T.tmpdir()
  local v, err = trace.diff(dir, dir)
  T.eq(v, nil)
  T.contains(err, "Is a directory")
  local out, rc = T.sh(string.format("'%s' trace diff '%s' '%s'", T.exe, dir, dir))
  T.eq(rc, 2, out)
  T.contains(out, "dca trace: " .. dir .. ": Is a directory")
  T.ok(not out:find("traceback", 1, true), out)
  T.cleanup()
end)

return suite:run(...)
