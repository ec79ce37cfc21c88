-- Colour on a terminal (dca.cli.colour): when it is on ($NO_COLOR, $TERM, $DCA_COLOR, a tty), what a run's line
-- and a check's diagnostics look like in it, and `dca check` on a real terminal (script(1) gives it a pty).
local T = require "dca.testing"
local colour = require "dca.cli.colour"
local suite = T.suite("colour")

local dca = T.exe
local ESC = "\27["

local function q(s) return "'" .. s:gsub("'", "'\\''") .. "'" end
local function env(t) return function(k) return t[k] end end
local function tty() return true end
local function pipe() return false end

suite:case("on_a_terminal_unless_no_color_or_a_dumb_terminal", function()
  T.eq(colour.on(1, env{ TERM = "xterm" }, tty), true)
  T.eq(colour.on(1, env{ TERM = "xterm" }, pipe), false, "not a terminal")
  T.eq(colour.on(1, env{ TERM = "xterm", NO_COLOR = "1" }, tty), false, "NO_COLOR set")
  T.eq(colour.on(1, env{ TERM = "xterm", NO_COLOR = "" }, tty), true, "NO_COLOR empty counts as unset (no-color.org)")
  T.eq(colour.on(1, env{ TERM = "dumb" }, tty), false)
  T.eq(colour.on(1, env{ DCA_COLOR = "always", NO_COLOR = "1" }, pipe), true)
  T.eq(colour.on(1, env{ DCA_COLOR = "never", TERM = "xterm" }, tty), false)
end)

suite:case("a_runs_states_and_a_checks_diagnostics_in_colour", function()
  T.eq(colour.line("[sim    2.010] main.a: aborted (why)"),
    ESC .. "2m[sim    2.010] " .. ESC .. "0mmain.a: " .. ESC .. "1;31maborted" .. ESC .. "0m (why)")
  T.eq(colour.line("[  1.000] main: DONE 1"), ESC .. "2m[  1.000] " .. ESC .. "0mmain: " .. ESC .. "32mDONE" .. ESC .. "0m 1")
  T.eq(colour.line("main.a: running"), "main.a: running", "a state that is no news stays plain")
  T.eq(colour.diag("f.dca:2:37: main.a: unknown\n  a instof Nope;\n       ^\nf.dca: 1 error"),
    ESC .. "1mf.dca:2:37:" .. ESC .. "0m main.a: unknown\n  a instof Nope;\n" .. ESC .. "32m       ^" .. ESC .. "0m\nf.dca: "
    .. ESC .. "1;31m1 error" .. ESC .. "0m")
end)

-- `dca check` of a file with an error on a terminal: coloured, and plain with NO_COLOR or into a pipe.
suite:case("dca_check_on_a_terminal_is_coloured_unless_no_color", function()
  local file = T.tmpname(".dca")
  local f = assert(io.open(file, "w"))
  f:write('process main() {\n  instantiated_processes { a instof Nope("h1"); }\n  internal_event_actions { a }\n}\n')
  f:close()
  local cmd = dca .. " check " .. file
  local out = T.sh("TERM=xterm script -qec " .. q(cmd) .. " /dev/null")
  T.contains(out, ESC .. "1m" .. file .. ":2:37:")
  T.contains(out, ESC .. "1;31m1 error")
  out = T.sh("TERM=xterm NO_COLOR=1 script -qec " .. q(cmd) .. " /dev/null")
  T.contains(out, file .. ":2:37:")
  T.ok(not out:find(ESC, 1, true), "no colour with NO_COLOR:\n" .. out)
  out = T.sh("TERM=xterm " .. cmd)
  T.ok(not out:find(ESC, 1, true), "no colour into a pipe:\n" .. out)
  os.remove(file)
end)

return suite:run(...)
