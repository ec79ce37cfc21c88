-- `dca check` as a user runs it.
local T = require "dca.testing"
local suite = T.suite("check")

local src, tmpfile = T.src, T.tmpfile

suite:case("paper_systems_pass_dca_check", function()
  local want = {
    compliant_motion = "ok: 2 groups, 7 instances (6 leaves), 6 connections, 2 hosts (arm, control)",
    door_open = "ok: 6 groups, 27 instances (22 leaves), 20 connections, 3 hosts (manipulation, platform, vision)",
    tidy_up = "ok: 2 groups, 8 instances (7 leaves), 0 connections, 2 hosts (arm, robot)",
  }
  for name, summary in pairs(want) do
    local path = src .. "/scripts/systems/" .. name .. ".dca"
    -- the language-level check, and the full one against the controller registry
    T.eq(T.dca("check --no-registry " .. path, 0), path .. ": " .. summary .. "\n")
    T.eq(T.dca("check " .. path, 0), path .. ": " .. summary .. "\n")
  end
end)

--- Writes the defaults file beside path. --> its path
local function defaults(path, text) return T.write((path:gsub("%.dca$", ".config")), text) end

suite:case("config_parameters_are_checked_against_the_defaults_file", function()
  local path = tmpfile([[use door;
process main() {
  instantiated_processes {
    det instof DistanceThreshold("h1", config("door.stop_distanse"));
    hit instof ForceThreshold("h1", config("door.hit_force"));
  }
  internal_event_actions { det , hit }
}
]])
  -- a key the defaults lack: a warning at the config( literal, with the close name
  local file = defaults(path, "door.stop_distance = 0.7\ndoor.hit_force = 6.0\n")
  T.dca("check " .. path, 0, path .. ":4:40: warning: main.det parameter 1 'distance': config key " ..
    "'door.stop_distanse' is not in " .. file .. " (did you mean door.stop_distance?)", path .. ": ok:")
  -- a default of the wrong type for the parameter: an error
  defaults(path, "door.stop_distanse = 0.7\ndoor.hit_force = \"six\"\n")
  T.dca("check " .. path, 1, path .. ":5:37: main.hit parameter 1 'force': config key 'door.hit_force' defaults to " ..
    "\"six\" in " .. file .. ", not a number")
  -- a defaults file that does not read: an error at its line and column; --no-config skips it
  defaults(path, "door.hit_force 6\n")
  T.dca("check " .. path, 1, file .. ":1:1: expected `key = value`")
  T.dca("check --no-config " .. path, 0)
  os.remove(file)
  os.remove(path)
end)

-- An error shows a window of its source line and a clipped message: a 50 MB one-line identifier gave a 157 MB
-- error (here 2 MB: the same path, quicker).
suite:case("a_huge_identifier_gives_an_error_of_bounded_size", function()
  local name = string.rep("X", 2000000)
  local path = tmpfile("process main() {\n  instantiated_processes { a instof " .. name .. "(\"h\"); }\n"
    .. "  internal_event_actions { a }\n}\n")
  local out, rc = T.sh(string.format("'%s' check '%s'", T.exe, path))
  T.eq(rc, 1, out:sub(1, 300))
  T.contains(out, path .. ":2:37: main.a: unknown process type 'XXXX")
  T.contains(out, "bytes more)")
  T.ok(#out < 6000, "the error is " .. #out .. " bytes")
  T.cleanup()
end)

suite:case("literal_parameters_are_held_to_their_ranges_and_allowed_values", function()
  local path = T.tmpfile([[
process main() {
  instantiated_processes {
    t  instof Timer("h", -1);
    th instof Threshold("h", 1, "upward");
    ok instof Threshold("h", 1, "falling");
  }
  internal_event_actions { t, th, ok }
}
]])
  T.dca("check " .. path, 1,
    path .. ":3:26: main.t: parameter 'seconds' of Timer must be at least 0, got -1",
    path .. ":4:33: main.th: parameter 'direction' of Threshold must be rising, falling or either, got 'upward'")
  local out = T.dca("check " .. path, 1)
  T.ok(not out:find("main.ok", 1, true), "an allowed value passes:\n" .. out)
  os.remove(path)
end)

suite:case("tree_option_prints_the_instances", function()
  local path = src .. "/worlds/door/systems/compliant_motion.dca"
  T.eq(T.dca("check --no-registry --tree " .. path, 0),
       path .. ": ok: 2 groups, 7 instances (6 leaves), 6 connections, 2 hosts (arm, control)\n" ..
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
  T.dca("check --no-registry " .. path, 1, path .. ":2:28: main.a: leaf 'a' (T) has no host",
    path .. ":3:32: main: unknown instance 'b' in internal_event_actions (instances: a)", path .. ": 2 errors")
  os.remove(path)
end)

suite:case("verify_section_errors_come_with_the_other_errors", function()
  -- a plain `dca check` (no --verify) reports a verify { } section's errors at file:line:col, in file order
  -- with the file's other errors, and exits 1
  local path = tmpfile([[use door;
process main() {
  instantiated_processes {
    stop instof Timer("h", 1);
    odd  instof NoSuchType("h");
  }
  internal_event_actions { stop }
  verify { ghost never starts before stop is done; main can end done; }
}
]])
  local out = T.dca("check " .. path, 1, path .. ":5:17: main.odd: unknown process type 'NoSuchType'",
    path .. ":8:12: main: no instance 'ghost' in process 'main'", path .. ": 2 errors")
  T.ok(not out:find(": ok:", 1, true), out)
  T.ok(out:find(":5:17:", 1, true) < out:find(":8:12:", 1, true), "in file order")
  os.remove(path)
end)

suite:case("registry_is_used_when_dca_core_has_types", function()
  local path = tmpfile("process main() {\n  instantiated_processes { t instof Timer(\"h\", 30); x instof NoSuchType(\"h\"); }\n" ..
                       "  internal_event_actions { t # x }\n}\n")
  T.dca("check --no-registry " .. path, 0)
  if type(require("dca.core").types) == "function" then
    T.dca("check " .. path, 1, ":2:62: main.x: unknown process type 'NoSuchType'")
  else
    T.dca("check " .. path, 0)  -- without dca.core.types undefined types are leaves
  end
  os.remove(path)
end)

-- Port types (docs/lua.md, "Port types"): each connection an output of the wrong type or size feeds is an error at
-- the connection, naming both ends and both types; the built-ins' vectorx ports meet scalars at the sizes they
-- are given or fed.
suite:case("port_types_and_sizes_are_checked_at_each_connection", function()
  local path = tmpfile([[use door;
process main() {
  instantiated_processes {
    three instof Constant("h", 0.01, 1, 2, 3);
    unfed instof Gain("h", 2);
    odom  instof XR4000Odometry("h");
    puma  instof Puma560Ctrl("h");
    level instof Threshold("h", 1);
  }
  internal_connections(level, run) {
    three, Out -> level, In;
    unfed, Out -> level, In;
    odom, Pose -> level, In;
  }
  internal_connections(puma, run) { odom, Pose -> puma, Vel; }
  internal_event_actions { level[run] # (three, unfed, odom, puma[run]) }
}
]])
  T.dca("check " .. path, 1,
    path .. ":11:5: main.three.Out (vectorx of size 3) cannot feed main.level.In (scalar)",
    path .. ":12:5: main.unfed.Out (vectorx) cannot feed main.level.In (scalar): dca check cannot tell how many " ..
      "values it writes",
    path .. ":13:5: main.odom.Pose (vector[3]) cannot feed main.level.In (scalar)",
    path .. ":15:37: main.odom.Pose (vector[3]) cannot feed main.puma.Vel (vector[6])", path .. ": 4 errors")
  os.remove(path)
  -- a Constant of one value feeds a scalar input, a Counter a Gain, and the Gain a scalar input
  path = tmpfile([[process main() {
  instantiated_processes {
    one instof Constant("h", 0.01, 1); ramp instof Counter("h", 0.01); g instof Gain("h", 2);
    a instof Threshold("h", 1); b instof Threshold("h", 1);
  }
  internal_connections(a, run) { one, Out -> a, In; }
  internal_connections(g, run) { ramp, Count -> g, In; g, Out -> b, In; }
  internal_event_actions { a[run] # (one, ramp, g[run], b) }
}
]])
  T.dca("check " .. path, 0, path .. ": ok: 1 group, 5 instances (5 leaves), 3 connections, 1 host (h)")
  os.remove(path)
end)

suite:case("every_system_in_scripts_systems_checks_clean", function()
  local names = T.list(src .. "/scripts/systems", "%.dca$")
  T.ok(#names > 10, "the systems")
  for _, name in ipairs(names) do
    local path = src .. "/scripts/systems/" .. name
    T.dca("check " .. path, 0, path .. ": ok: ")
  end
end)

-- The world's signals (docs/lua.md, "Port types"): --sim WORLD, as `dca run` takes it, chooses the signals the
-- leaves' device ports are held to: the door's by default, a URDF's joint ports.
local ur10_system, ur10 = src .. "/worlds/ur10/ur10_setpoint.dca", src .. "/worlds/ur10/ur10.urdf"

suite:case("a_urdf_system_checks_against_its_urdf_and_fails_against_the_door_naming_the_signals", function()
  local ok = ur10_system .. ": ok: 1 group, 2 instances (2 leaves), 0 connections, 1 host (arm)\n"
  T.eq(T.dca("check " .. ur10_system .. " --sim " .. ur10, 0), ok)
  T.eq(T.dca("check " .. ur10_system .. " --sim 'mock:" .. ur10 .. "?lag=0.02&dead=elbow_joint'", 0), ok)
  T.dca("check " .. ur10_system .. " --sim " .. ur10 .. " --verify", 0, "can end DONE with wrist", "verified: 1 group")
  for _, door in ipairs({ " --sim door", "" }) do
    T.dca("check " .. ur10_system .. door, 1,
      ur10_system .. ":10:5: main.elbow.Cmd (vector[1], device port of JointSetpoint): the world has no command "
        .. "'joint.elbow_joint.position_command'",
      ur10_system .. ":10:5: main.elbow.Q (vector[1], device port of JointSetpoint): the world has no sensor "
        .. "'joint.elbow_joint.position'",
      ur10_system .. ":11:5: main.wrist.Cmd (vector[1], device port of JointSetpoint): the world has no command "
        .. "'joint.wrist_1_joint.velocity_command'",
      ur10_system .. ": 6 errors")
  end
  -- and the door's system against the UR10: the door's signals are missing there
  local door_open = src .. "/worlds/door/systems/door_open.dca"
  T.dca("check " .. door_open .. " --sim " .. ur10, 1, "the world has no sensor 'arm.q'")
end)

suite:case("a_joint_or_interface_the_urdf_lacks_is_an_error_at_the_leaf", function()
  local path = tmpfile([[process main() {
  instantiated_processes {
    a instof JointSetpoint("arm", "elbow", 1.0);
    b instof JointSetpoint("arm", "elbow_joint", 1.0);
  }
  internal_event_actions { a ; b }
}
]])
  local out = T.dca("check " .. path .. " --sim " .. ur10, 1,
    path .. ":3:5: main.a.Q (vector[1], device port of JointSetpoint): the world has no sensor 'joint.elbow.position'")
  T.ok(not out:find("main.b.", 1, true), "b's joint is the UR10's: " .. out)
  -- an interface JointSetpoint does not offer is its parameter's error, before the world is asked
  T.write(path, (T.read(path):gsub('"elbow_joint", 1.0%)', '"elbow_joint", 1.0, 0.01, "effort")')))
  T.dca("check " .. path .. " --sim " .. ur10, 1, path .. ":4:61: main.b: parameter 'interface' of JointSetpoint " ..
    "must be position or velocity, got 'effort'")
  os.remove(path)
end)

suite:case("a_world_that_does_not_load_is_one_error_at_its_own_file_and_line", function()
  local urdf = T.tmpfile('<robot name="x">\n<link name="a"/>\n'
    .. '<joint name="j" type="revolute"><parent link="zz"/><child link="a"/></joint>\n</robot>\n', ".urdf")
  T.eq(T.dca("check " .. ur10_system .. " --sim " .. urdf, 1),
       urdf .. ":3:1: joint 'j': its parent link 'zz' is not defined\n")
  -- after the file's own errors, once
  local path = tmpfile('process main() {\n  instantiated_processes { a instof Nope("h"); }\n  internal_event_actions { a }\n}\n')
  local out = T.dca("check " .. path .. " --sim " .. urdf, 1, path .. ":2:")
  T.ok(out:find(urdf .. ":3:1: joint 'j'", 1, true) > out:find(path .. ":2:", 1, true), out)
  T.eq(select(2, out:gsub("its parent link 'zz'", "")), 1, "once: " .. out)
  T.dca("check " .. ur10_system .. " --sim nowhere", 1, "world 'nowhere': no such world (`dca sim --worlds` lists them; or ROBOT.urdf, mock:ROBOT.urdf)")
  T.dca("check " .. ur10_system .. " --sim 'mock:" .. ur10 .. "?dead=nope'", 1,
        "mock:", "dead=nope: the robot has no moving joint of that name")
  os.remove(urdf)
  os.remove(path)
end)

suite:case("syntax_error_exit_1_with_caret", function()
  local path = tmpfile("process main() {\n  host (h)\n}\n")
  T.eq(T.dca("check " .. path, 1), path .. ":2:8: 'host' takes braces, not parentheses: write 'host { h }'\n  host (h)\n       ^\n")
  os.remove(path)
end)

suite:case("usage_errors_exit_2", function()
  T.dca("check", 2, "usage: dca check FILE.dca")
  T.dca("check /nonexistent/x.dca", 1, "cannot read /nonexistent/x.dca")
  T.dca("check a.dca b.dca", 2, "unexpected argument 'b.dca'")
  T.dca("check --root", 2, "--root needs a value", "usage: dca check FILE.dca")
end)

return suite:run(...)
