-- `dca check` and `dca graph` as a user runs them.
local T = require "dca.testing"
local suite = T.suite("check_cli")

local dca = os.getenv("DCA_EXE") or "dca"
local src = os.getenv("DCA_SOURCE_DIR") or "."

local function tmpfile(text)
  local path = os.tmpname() .. ".dca"
  local f = assert(io.open(path, "w"))
  f:write(text)
  f:close()
  return path
end

suite:case("paper_systems_pass_dca_check", function()
  local want = {
    compliant_motion = "ok: 2 groups, 7 instances (6 leaves), 6 connections, 2 hosts (arm, control)",
    door_open = "ok: 6 groups, 27 instances (22 leaves), 20 connections, 3 hosts (manipulation, platform, vision)",
    tidy_up = "ok: 2 groups, 8 instances (7 leaves), 0 connections, 2 hosts (arm, robot)",
  }
  for name, summary in pairs(want) do
    local path = src .. "/scripts/systems/" .. name .. ".dca"
    -- the language-level check, and the full one against the controller registry
    local out, rc = T.sh(dca .. " check --no-registry " .. path)
    T.eq(rc, 0, name .. ": " .. out)
    T.eq(out, path .. ": " .. summary .. "\n")
    out, rc = T.sh(dca .. " check " .. path)
    T.eq(rc, 0, name .. ": " .. out)
    T.eq(out, path .. ": " .. summary .. "\n")
  end
end)

suite:case("config_parameters_are_checked_against_the_defaults_file", function()
  local path = tmpfile([[
process main() {
  instantiated_processes {
    det instof DistanceThreshold("h1", config("door.stop_distanse"));
    hit instof ForceThreshold("h1", config("door.hit_force"));
  }
  internal_event_actions { det , hit }
}
]])
  local defaults = path:gsub("%.dca$", ".config")
  local f = assert(io.open(defaults, "w"))
  f:write("door.stop_distance = 0.7\ndoor.hit_force = 6.0\n")
  f:close()
  -- a key the defaults lack: a warning at the config( literal, with the close name
  local out, rc = T.sh(dca .. " check " .. path)
  T.eq(rc, 0, out)
  T.contains(out, path .. ":3:40: warning: main.det parameter 1 'distance': config key 'door.stop_distanse' is not in "
    .. defaults .. " (did you mean door.stop_distance?)")
  T.contains(out, path .. ": ok:")
  -- a default of the wrong type for the parameter: an error
  f = assert(io.open(defaults, "w"))
  f:write("door.stop_distanse = 0.7\ndoor.hit_force = \"six\"\n")
  f:close()
  out, rc = T.sh(dca .. " check " .. path)
  T.eq(rc, 1, out)
  T.contains(out, path .. ":4:37: main.hit parameter 1 'force': config key 'door.hit_force' defaults to \"six\" in "
    .. defaults .. ", not a number")
  -- a defaults file that does not read: an error at its line and column; --no-config skips it
  f = assert(io.open(defaults, "w"))
  f:write("door.hit_force 6\n")
  f:close()
  out, rc = T.sh(dca .. " check " .. path)
  T.eq(rc, 1, out)
  T.contains(out, defaults .. ":1:1: expected `key = value`")
  out, rc = T.sh(dca .. " check --no-config " .. path)
  T.eq(rc, 0, out)
  os.remove(defaults)
  os.remove(path)
end)

suite:case("tree_option_prints_the_instances", function()
  local path = src .. "/scripts/systems/compliant_motion.dca"
  local out, rc = T.sh(dca .. " check --no-registry --tree " .. path)
  T.eq(rc, 0, out)
  T.eq(out, path .. ": ok: 2 groups, 7 instances (6 leaves), 6 connections, 2 hosts (arm, control)\n" ..
            "main : main  { motion }\n" ..
            "  motion : CompliantMotion @control  { hit # (forcedata[lbl1], compliant[lbl1], joints, redundancy[lbl1], puma) }\n" ..
            "    forcedata : ForceTorque @control\n" ..
            "    compliant : CompliantCtrl @control\n" ..
            "    joints : Puma560Joints @control\n" ..
            "    redundancy : RedundancyResolution @arm\n" ..
            "    puma : Puma560Ctrl @arm\n" ..
            "    hit : ForceThreshold @control (40)\n")
end)

suite:case("errors_are_printed_and_exit_1", function()
  local path = tmpfile("process main() {\n  instantiated_processes { a instof T(); }\n  internal_event_actions { a , b }\n}\n")
  local out, rc = T.sh(dca .. " check --no-registry " .. path)
  os.remove(path)
  T.eq(rc, 1)
  T.contains(out, path .. ":2:28: main.a: leaf 'a' (T) has no host")
  T.contains(out, path .. ":3:32: main: unknown instance 'b' in internal_event_actions (instances: a)")
  T.contains(out, path .. ": 2 errors")
end)

suite:case("registry_is_used_when_dca_core_has_types", function()
  local path = tmpfile("process main() {\n  instantiated_processes { t instof Timer(\"h\", 30); x instof NoSuchType(\"h\"); }\n" ..
                       "  internal_event_actions { t # x }\n}\n")
  local out, rc = T.sh(dca .. " check " .. path)
  local out2, rc2 = T.sh(dca .. " check --no-registry " .. path)
  os.remove(path)
  T.eq(rc2, 0, out2)
  if type(require("dca.core").types) == "function" then
    T.eq(rc, 1, out)
    T.contains(out, ":2:62: main.x: unknown process type 'NoSuchType'")
  else
    T.eq(rc, 0, "without dca.core.types undefined types are leaves: " .. out)
  end
end)

suite:case("syntax_error_exit_1_with_caret", function()
  local path = tmpfile("process main() {\n  host (h)\n}\n")
  local out, rc = T.sh(dca .. " check " .. path)
  os.remove(path)
  T.eq(rc, 1)
  T.eq(out, path .. ":2:8: 'host' takes braces, not parentheses: write 'host { h }'\n  host (h)\n       ^\n")
end)

suite:case("usage_errors_exit_2", function()
  local out, rc = T.sh(dca .. " check")
  T.eq(rc, 2)
  T.contains(out, "usage: dca check FILE.dca")
  out, rc = T.sh(dca .. " check /nonexistent/x.dca")
  T.eq(rc, 1)
  T.contains(out, "cannot read /nonexistent/x.dca")
  _, rc = T.sh(dca .. " check a.dca b.dca")
  T.eq(rc, 2)
end)

suite:case("graph_writes_dot", function()
  local out, rc = T.sh(dca .. " graph --no-registry " .. src .. "/scripts/systems/door_open.dca")
  T.eq(rc, 0, out)
  T.ok(out:match("^digraph dca {\n"), out)
  T.contains(out, '"main.dooropensyst" [shape=folder')
  T.contains(out, "motionctrl # ((visualserv[lbl1], camera) # distdetect ; (opengrip, approach[lbl1]) # hit")
  T.contains(out, '"main.dooropensyst" -> "main.dooropensyst.hit";')
  T.contains(out, '"main.dooropensyst.visualserv" -> "main.dooropensyst.motionctrl" [style=dotted')
  T.contains(out, '"main.dooropensyst.opengrip" [shape=box, label="opengrip : GripperControl\\n@manipulation\\n(\\"open\\")"];')
end)

suite:case("graph_svg_when_dot_is_installed", function()
  local _, has_dot = T.sh("command -v dot")
  local out_path = os.tmpname() .. ".svg"
  local out, rc = T.sh(dca .. " graph --no-registry --svg -o " .. out_path .. " " .. src .. "/scripts/systems/tidy_up.dca")
  if has_dot ~= 0 then
    T.eq(rc, 1)
    T.contains(out, "not installed")
    return
  end
  T.eq(rc, 0, out)
  local f = assert(io.open(out_path))
  local svg = f:read("a")
  f:close()
  os.remove(out_path)
  T.contains(svg, "<svg")
  T.contains(svg, "main.tidy")
end)

return suite:run(...)
