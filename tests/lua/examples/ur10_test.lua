-- examples/ur10/pick_and_place.dca end to end (docs/robots.md, "The UR10 pick and place"): the UR10 through a
-- pick-like sequence with joint_control's JointTrajectory, under a Deadline, ends DONE in the Simbody world and on
-- mock hardware; a dead drive ends it ABORTED naming the joint and the waypoint; `dca check --verify` is clean;
-- JointPD drives two of its joints to targets.
local T = require "dca.testing"
local suite = T.suite("ur10")

local dca, src = T.exe, T.src
local system = src .. "/examples/ur10/pick_and_place.dca"
local ur10 = src .. "/worlds/ur10/ur10.urdf"

local function run(world)
  return T.sh("timeout 200 " .. dca .. " run " .. system .. " --sim '" .. world .. "'")
end

-- What both worlds show of a run to DONE: both legs done, the arm home, nothing clamped, and only the six joints'
-- slots of each leaf wired (3 ports a joint, 2 leaves: the two unused slots of each are not).
local function ends_done(out, rc)
  T.eq(rc, 0, "exit code\n" .. out)
  T.contains(out, "main.pick: done")
  T.contains(out, "main.place: done")
  T.contains(out, "main: DONE")
  T.contains(out, "main: 36 device ports wired to the world")
  T.contains(out, "joints at the end: elbow_joint 1.57")
  T.contains(out, "safety: no command clamped, no watchdog tripped")
  T.ok(not out:find("main.limit: done", 1, true), "the deadline did not fire:\n" .. out)
end

suite:case("the_pick_and_place_ends_done_in_the_simbody_world", function()
  ends_done(run(ur10))
end)

suite:case("the_same_file_ends_done_on_mock_hardware", function()
  ends_done(run("mock:" .. ur10))
end)

suite:case("a_dead_elbow_ends_it_aborted_naming_the_joint_and_the_waypoint", function()
  local out, rc = run("mock:" .. ur10 .. "?dead=elbow_joint")
  T.ok(rc ~= 0, "exit code\n" .. out)
  T.contains(out, "main.pick: aborted: waypoint 1 of 4 not reached within 20 s: joint elbow_joint at 1.5708, "
    .. "wanted 1.6 (tolerance 0.01)")
  T.ok(not out:find("main.place: running", 1, true), "place never starts:\n" .. out)
end)

-- joint_control's other controller on the same robot: a PD through the velocity command, for 3 s (a Timer).
suite:case("joint_pd_brings_two_ur10_joints_to_their_targets_through_the_velocity_command", function()
  local file = T.tmpfile([[
use joint_control;
process main() {
  instantiated_processes {
    hold instof JointPD("arm", "shoulder_pan_joint, elbow_joint", 4, 0, "velocity", 0.01, 0.5, 1.2);
    settle instof Timer("arm", 3);
  }
  internal_event_actions { hold # settle }
}
]])
  local out, rc = T.sh("timeout 200 " .. dca .. " run " .. file .. " --sim '" .. ur10 .. "'")
  T.eq(rc, 0, "exit code\n" .. out)
  T.contains(out, "main: 6 device ports wired to the world")
  T.contains(out, "main: DONE")
  T.contains(out, "elbow_joint 1.20")
  T.contains(out, "shoulder_pan_joint 0.50")
  T.cleanup()
end)

suite:case("dca_check_verify_of_the_example_is_clean", function()
  local out, rc = T.sh(dca .. " check --verify " .. system .. " --sim " .. ur10)
  T.eq(rc, 0, "exit code\n" .. out)
  T.contains(out, "0 findings, 0 violated properties, faults on")
  T.contains(out, "holds     place never starts before pick is done")
  T.contains(out, "holds     main can end done")
  T.contains(out, "can end DONE with place")
end)

return suite:run(...)
