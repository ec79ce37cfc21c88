-- Errors surface: a world that fails to start shows its own message in the output of the command that
-- started it. Without this, `dca run --sim door` with a broken robot URDF said only "the world (dca sim
-- --serve) exited with code 1 on host manip"; the XML error with file:line was in a daemon log the run deleted.
local T = require "dca.testing"
local core = require "dca.core"
local suite = T.suite("errors")

local dca, src = T.exe, T.src

suite:case("a_world_with_a_broken_urdf_says_the_xml_error_with_file_and_line", function()
  local dir = T.tmpdir()
  for _, name in ipairs(assert(core.list_dir(src .. "/worlds/door/models"))) do
    if name:find("%.urdf$") then T.write(dir .. "/" .. name, T.read(src .. "/worlds/door/models/" .. name)) end
  end
  local urdf = dir .. "/mobile_manipulator.urdf"
  local text = T.read(urdf)
  local first_link = text:find("<link", text:find("<robot name", 1, true), true)
  local eol = text:find("\n", first_link, true)
  T.write(urdf, text:sub(1, eol) .. '  <link name="broken">\n' .. text:sub(eol + 1))  -- never closed
  local out, rc = T.sh("DCA_MODELS_DIR=" .. dir .. " timeout 60 " .. dca .. " run " .. src
    .. "/scripts/systems/test_three_hosts.dca --sim door")
  core.remove_tree(dir)
  T.kept_logs(out)
  T.eq(rc, 3, "exit code (the start failed)\n" .. out)
  T.contains(out, "the world (dca sim --serve) exited with code 1")
  T.contains(out, "dca sim: " .. urdf .. ":")
  T.contains(out, "not well-formed XML")
end)

-- `dca run` of a system whose group `ctl` holds a good leaf and leaf `filt` of type `ty` from test package
-- `pkg` (tests/packages, on the controller path), `extra` after the file on its command line. --> output, exit code
local function run_ctl(pkg, leaf, extra)
  local dir = os.getenv("DCA_TEST_PACKAGES_DIR") or error("DCA_TEST_PACKAGES_DIR is not set")
  local path = T.tmpfile("use " .. pkg .. ";\n" .. [[
process Ctl(h1) {
  host { h1 }
  instantiated_processes { ok instof Counter(h1, 0.01); filt instof ]] .. leaf .. [[; }
  internal_event_actions { ok , filt }
}
process main() {
  instantiated_processes { ctl instof Ctl("h1"); }
  internal_event_actions { ctl }
}
]])
  local out, rc = T.sh("DCA_CONTROLLER_PATH=" .. dir .. " timeout 60 " .. dca .. " run " .. path .. " " .. (extra or ""))
  os.remove(path)
  return out, rc, T.kept_logs(out, true)
end

-- A node that fails before it is ready tells its daemon why; the reason comes with its exit: said at its leaf,
-- then the start fails with it, at once (no wait for a lookup's deadline).
local function fails_at_once(out, rc, reason)
  T.eq(rc, 3, "exit code (the start failed)\n" .. out)
  local said = out:find("] main.ctl.filt: " .. reason, 1, true)
  T.ok(said, "the reason at the leaf\n" .. out)
  local failed = out:find("start failed: main.ctl.filt: " .. reason, 1, true)
  T.ok(failed and failed > said, "the start failed with the reason, after the leaf's line\n" .. out)
  T.ok(not out:find("within 10000 ms", 1, true), "no lookup ran to its deadline\n" .. out)
end

suite:case("a_parameter_out_of_range_fails_the_start_with_its_reason_at_once", function()
  -- from the repository, so that dca check cannot see it (a literal is held to the range there)
  local out, rc, kept = run_ctl("pkg_positive", 'PkgPositive(h1, config("test.k"))', "--set test.k=-0.005")
  T.kept_logs(out)
  fails_at_once(out, rc, "parameter 'k' must be positive, got -0.005 (exited with code 1 on host h1)")
  T.ok(kept, "the logs' folder is named\n" .. out)
end)

suite:case("a_mistyped_port_name_fails_the_start_with_its_reason_at_once", function()
  local out, rc = run_ctl("pkg_port_typo", "PkgPortTypo(h1)")
  T.kept_logs(out)
  fails_at_once(out, rc,
    "no input 'SetPoint' on main.ctl.filt; inputs are: In (list it in Describe()) (exited with code 1 on host h1)")
end)

-- A failed run keeps its daemons' logs (the key goes) in a folder it names last, under $DCA_RUN_LOGS (the tests'
-- env sets it), else $TMPDIR.
suite:case("a_failed_run_keeps_its_daemons_logs_and_says_where", function()
  -- from the repository, so that dca check cannot see it (a literal is held to the range there)
  local out, rc, kept = run_ctl("pkg_positive", 'PkgPositive(h1, config("test.k"))', "--set test.k=-0.005")
  T.eq(rc, 3, "exit code (the start failed)\n" .. out)
  T.ok(kept, "the logs' folder is named\n" .. out)
  local log = T.exists(kept .. "/h1.log") and T.read(kept .. "/h1.log") or ""
  T.kept_logs(out)
  T.contains(log, "dca daemon h1: main.ctl.filt (pid ")
  T.contains(log, ") failed to start: parameter 'k' must be positive, got -0.005")
  T.contains(log, "dca node: main.ctl.ok ready")
  local under = os.getenv("DCA_RUN_LOGS") or os.getenv("TMPDIR") or "/tmp"
  T.eq(kept:sub(1, #under + 1), under .. "/", "under $DCA_RUN_LOGS, else $TMPDIR")
  T.ok(out:find("kept in " .. kept .. "/ (h1.log)\n", 1, true) == #out - #("kept in " .. kept .. "/ (h1.log)\n") + 1,
    "the last line names it\n" .. out)
end)

-- A controller's stderr reaches the run's output line by line, prefixed by its path, from a leaf on any host
-- (its daemon sends the lines to the leaf's supervisor); a flood is cut to the budget and the rest counted.
suite:case("a_controllers_stderr_lines_reach_the_run_output_prefixed_by_its_path", function()
  local dir = os.getenv("DCA_TEST_PACKAGES_DIR") or error("DCA_TEST_PACKAGES_DIR is not set")
  local path = T.tmpfile([[
use pkg_stderr;
process Talk(h1) {
  host { h1 }
  instantiated_processes { say instof PkgStderr(h1, 3, 0.01); }
  internal_event_actions { say }
}
process main() {
  instantiated_processes { talk instof Talk("h1"); flood instof PkgStderr("h2", 50000, 0.01); }
  internal_event_actions { talk , flood }
}
]])
  local out, rc = T.sh("DCA_CONTROLLER_PATH=" .. dir .. " timeout 60 " .. dca .. " run " .. path)
  os.remove(path)
  T.eq(rc, 0, "exit code\n" .. out)
  for i = 1, 3 do T.contains(out, "] main.talk.say: line " .. i .. " of PkgStderr\n") end
  T.contains(out, "] main.flood: line 1 of PkgStderr\n")
  local shown = select(2, out:gsub("main%.flood: line %d+ of PkgStderr\n", ""))
  local left = 0
  for n in out:gmatch("main%.flood: %((%d+) lines of its output left out here") do left = left + tonumber(n) end
  T.eq(shown + left, 50000, "every line of the flood shown or counted\n" .. out:sub(1, 2000))
end)

return suite:run(...)
