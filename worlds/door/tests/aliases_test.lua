-- The door world's arm through the generic joint interfaces (docs/worlds.md, "Joint aliases"): a controller of
-- any URDF robot (JointSetpoint) drives an arm joint of the door robot by its URDF name and ends DONE at its
-- target; the alias and the arm's vector input are one actuator, so a second writer on either is refused and
-- named with both paths; `dca types --world door` and `dca check --verify` know them.
local T = require "dca.testing"
local suite = T.suite("door")

local dca = T.exe
local sformat = string.format

-- JointSetpoint on arm_joint_2 through joint.arm_joint_2.velocity_command; `more` instances run beside it.
local function system(target, more, expr)
  return sformat([[
process main() {
  instantiated_processes {
    j instof JointSetpoint("manipulation", "arm_joint_2", %s, 0.01, "velocity");
    limit instof Deadline("manipulation", 20);
    %s
  }
  internal_event_actions { %s }
}
]], target, more or "", expr or "j # limit")
end

local function run(text, more)
  local dir = T.tmpdir()
  T.write(dir .. "/sys.dca", text)
  local trace = dir .. "/run.trace"
  local out, rc = T.sh("timeout 120 " .. dca .. " run " .. dir .. "/sys.dca --sim door --seed 0 --trace " .. trace
                       .. (more or ""))
  return out, rc, trace
end

suite:case("an_arm_joint_driven_through_its_alias_reaches_its_target", function()
  local out, rc = run(system("1.2"))
  T.eq(rc, 0, out)
  local q = tonumber(out:match("main%.j: done (%-?[%d.]+)"))
  T.ok(q and math.abs(q - 1.2) < 0.011, "JointSetpoint ends DONE within its tolerance of 1.2: " .. out)
  T.contains(out, "main: DONE")
end)

suite:case("the_alias_and_the_vector_are_one_actuator_a_second_writer_is_refused", function()
  local out, rc, trace = run(system("1.2", 'drive instof Puma560Ctrl("manipulation");', "(drive , j) # limit"))
  T.ok(rc ~= nil, out)
  -- one of the two holds the arm, the other's samples are refused, both named, on whichever input it wrote
  local input, refused, holder = out:match("\n%s+([%w_%.]+): (main%.%w+%.Cmd) refused, held by (main%.%w+%.Cmd) at")
  T.ok(input and refused ~= holder, "a second writer named with both paths: " .. out)
  local paths = { [refused] = true, [holder] = true }
  T.ok(paths["main.drive.Cmd"] and paths["main.j.Cmd"], "the vector's writer and the alias's: " .. out)
  T.ok(input == "arm.cmd_qd" or input == "joint.arm_joint_2.velocity_command", input)
  T.contains(out, "second writer refused on " .. input .. ": ")
  -- the refused writer's supervisor says it, with both paths
  T.contains(out, sformat("%s: second writer refused on world.%s: %s, held by %s", refused:match("^(main%.%w+)"),
                          input, refused, holder))
  local n = 0
  for line in T.read(trace):gmatch("[^\n]+") do
    if line:find(" W world." .. input .. " refused=" .. refused .. " holder=" .. holder, 1, true) then n = n + 1 end
  end
  T.ok(n > 0, "refused samples traced")
end)

suite:case("dca_types_lists_the_aliases_of_the_door_world", function()
  local out, rc = T.sh(dca .. " types --world door")
  T.eq(rc, 0, out)
  for k = 1, 6 do
    for _, s in ipairs({ "position", "velocity", "effort", "velocity_command" }) do
      T.contains(out, sformat("joint.arm_joint_%d.%s", k, s))
    end
  end
end)

suite:case("verify_counts_the_alias_and_the_vector_as_one_actuator", function()
  local dir = T.tmpdir()
  T.write(dir .. "/sys.dca", system("1.2", 'drive instof Puma560Ctrl("manipulation");', "(drive , j) # limit"))
  local out = T.sh(dca .. " check " .. dir .. "/sys.dca --sim door --verify")
  local a, b = out:match("FINDING two writers on world%.arm%.cmd_qd: (main%.%w+%.Cmd) and (main%.%w+%.Cmd) can write")
  T.ok(a and b, "the vector's writer and the alias's on one actuator: " .. out)
  T.eq({ [a] = true, [b] = true }, { ["main.drive.Cmd"] = true, ["main.j.Cmd"] = true })
end)
return suite:run(...)
