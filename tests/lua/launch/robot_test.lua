-- The URDF world end to end (docs/robots.md): worlds/ur10/ur10_setpoint.dca drives the UR10's elbow, then a
-- wrist joint, to their setpoints through JointSetpoint's device ports and ends DONE, in the Simbody world and on
-- the mock hardware; a target beyond the joint's limit is clamped, counted in the summary and in the trace; a
-- broken URDF stops the run's check with its file:line error; `dca types --world` lists the ports.
local T = require "dca.testing"
local suite = T.suite("robot")

local dca, src = T.exe, T.src
local system = src .. "/worlds/ur10/ur10_setpoint.dca"
local ur10 = src .. "/worlds/ur10/ur10.urdf"

local function run(dca_file, world, more)
  return T.sh("timeout 120 " .. dca .. " run " .. dca_file .. " --sim '" .. world .. "'" .. (more or ""))
end

suite:case("the_ur10_elbow_reaches_its_setpoint_in_the_simbody_world", function()
  local out, rc = run(system, ur10)
  T.eq(rc, 0, "exit code\n" .. out)
  T.contains(out, "main.elbow: done 0.99")
  T.contains(out, "main: DONE -1.00")
  T.contains(out, "joints at the end: elbow_joint 1.00")
  T.contains(out, "main: 6 device ports wired to the world")
end)

suite:case("the_same_system_runs_to_done_on_the_mock_hardware", function()
  local out, rc = run(system, "mock:" .. ur10 .. "?lag=0.02")
  T.eq(rc, 0, "exit code\n" .. out)
  T.contains(out, "main: DONE -1.00")
  T.contains(out, "joints at the end: elbow_joint 1.00")
end)

-- The monitor's token goes to the terminal only: never into the recording (its /dca/events lines are what a
-- replay shows, to whoever has the file).
suite:case("the_monitor_token_is_said_on_the_terminal_and_never_recorded", function()
  local mcap = T.tmpname(".mcap")
  local out, rc = run(system, ur10, " --monitor 127.0.0.1:0 --as-fast-as-possible --record " .. mcap)
  T.eq(rc, 0, "exit code\n" .. out)
  local token = out:match("monitor: http://%S+%?token=(%x+)")
  T.ok(token, "the monitor's line with its token:\n" .. out)
  T.contains(out, "foxglove: ws://")
  local bytes = T.mcap_text(mcap)
  T.contains(bytes, "main: DONE", "the run's lines are recorded")
  T.ok(not bytes:find(token, 1, true), "the token is not in the recording")
  T.ok(not bytes:find("?token=", 1, true), "no URL with a token in the recording")
  T.cleanup()
end)

suite:case("a_target_beyond_the_limit_is_clamped_and_counted_in_the_summary_and_the_trace", function()
  local file = src .. "/tests/lua/launch/systems/elbow_beyond_limit.dca"
  local trace = T.tmpname(".trace")
  local out = run(file, "mock:" .. ur10, " --trace " .. trace)
  T.contains(out, "main.elbow: aborted")
  T.contains(out, "joints at the end: elbow_joint 3.0916")  -- pi - 0.05, the soft limit
  T.contains(out, "joint.elbow_joint.position_command: 29 of 29 samples clamped, stale 0 times")
  T.contains(T.read(trace), "D world.safety.clamps n=3 digest=")
  T.contains(T.read(trace), "value=[0, 0, 0, 0, 2, 0, 0, 0, 0, 0, 0, 0]")
end)

suite:case("a_broken_urdf_stops_the_run_with_its_file_and_line", function()
  local urdf = T.tmpfile('<robot name="x">\n<link name="a"/>\n'
    .. '<joint name="j" type="revolute"><parent link="zz"/><child link="a"/></joint>\n</robot>\n', ".urdf")
  local out, rc = run(system, urdf)
  T.eq(rc, 2, "exit code (the check failed: nothing started)\n" .. out)
  T.eq(out, urdf .. ":3:1: joint 'j': its parent link 'zz' is not defined\n", "the one error, once")
end)

suite:case("the_run_checks_the_system_against_the_world_it_was_given", function()
  local out, rc = run(system, "door")
  T.eq(rc, 2, "exit code (the check failed: nothing started)\n" .. out)
  T.contains(out, "main.elbow.Cmd (vector[1], device port of JointSetpoint): the world has no command "
    .. "'joint.elbow_joint.position_command'")
  T.ok(not out:find("world: starting", 1, true), "no world started: " .. out)
end)

suite:case("dca_types_lists_the_ports_of_a_world", function()
  local out, rc = T.sh(dca .. " types --world " .. ur10)
  T.eq(rc, 0, out)
  T.contains(out, "in     joint.elbow_joint.position_command")
  T.contains(out, "out    joint.wrist_3_joint.effort")
  T.contains(out, "out    safety.stale                             vector[12]")
end)

return suite:run(...)
