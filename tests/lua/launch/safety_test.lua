-- One writer at a time on a robot's command input (docs/safety.md): two leaves that command one joint at the same
-- time. The world takes the first writer's samples and refuses the second's at the tick they come, counted,
-- traced and said in the summary with both paths; the joint goes where its one writer sends it.
local T = require "dca.testing"
local suite = T.suite("safety")

local dca, src = T.exe, T.src
local sformat = string.format
local ur10 = src .. "/worlds/ur10/ur10.urdf"

-- Two JointSetpoint leaves on the elbow, concurrently
local TWO_WRITERS = T.read(src .. "/tests/lua/launch/systems/two_writers.dca")

-- `dca run` of the system `text` on the mock UR10 with a trace, which must end with code 0: its output, the trace
local function run_traced(text)
  local dir = T.tmpdir()
  T.write(dir .. "/sys.dca", text)
  local trace = dir .. "/run.trace"
  local out, rc = T.sh("timeout 120 " .. dca .. " run " .. dir .. "/sys.dca --sim mock:" .. ur10 .. " --trace " .. trace)
  T.eq(rc, 0, out)
  return out, trace
end

suite:case("a_second_writer_on_a_joint_is_refused_at_its_tick_and_named_with_the_holder", function()
  local out, trace = run_traced(TWO_WRITERS)
  T.contains(out, "second writer refused on joint.elbow_joint.position_command: ")
  local refused, holder = out:match("joint%.elbow_joint%.position_command: (main%.%w+%.Cmd) refused, held by (main%.%w+%.Cmd) at")
  T.ok(holder and refused and holder ~= refused, "both paths named: " .. out)
  -- the refused writer's supervisor is told (an event with both paths) and says it, at the refusal's tick
  local line = out:match("%[sim%s+[%d.]+%] (main%.%w+: second writer refused on world%.joint%.elbow_joint%.position_command: [^\n]*)")
  T.eq(line, sformat("%s: second writer refused on world.joint.elbow_joint.position_command: %s, held by %s",
                     refused:match("^(main%.%w+)"), refused, holder), out)
  -- the holder ends first, at its own target; then the refused one takes the joint to its own
  local first = holder:match("^main%.(%w+)")
  local second = refused:match("^main%.(%w+)")
  local t_first = tonumber(out:match("%[sim%s+([%d.]+)%] main%." .. first .. ": done"))
  local t_second = tonumber(out:match("%[sim%s+([%d.]+)%] main%." .. second .. ": done"))
  T.ok(t_first and t_second and t_first < t_second, "the holder is done before the refused writer: " .. out)
  T.contains(out, second == "up" and "elbow_joint 1.0000" or "elbow_joint -1.0000")
  -- every refused sample is in the trace at its tick, naming both
  local n = 0
  for line in T.read(trace):gmatch("[^\n]+") do
    if line:find(" W world.joint.elbow_joint.position_command refused=" .. refused .. " holder=" .. holder, 1, true) then
      n = n + 1
    end
  end
  local count = tonumber(out:match("second writer refused on joint%.elbow_joint%.position_command: (%d+) samples"))
  T.eq(n, count, "one trace line per refused sample")
  T.ok(n > 0, "refused samples traced")
end)

suite:case("writers_one_after_the_other_are_no_second_writer", function()
  local dir = T.tmpdir()
  T.write(dir .. "/seq.dca", (TWO_WRITERS:gsub("%(up , down%) # limit", "(up ; down) # limit")))
  local out, rc = T.sh("timeout 120 " .. dca .. " run " .. dir .. "/seq.dca --sim mock:" .. ur10)
  T.eq(rc, 0, out)
  T.ok(not out:find("second writer", 1, true), "no refusal: " .. out)
end)

-- A restart never overlaps its old instance on an actuator: a velocity JointSetpoint that aborts every 0.3 s is
-- restarted by its group's policy three times; every tick of the trace has the commands of one instance at most,
-- no sample is refused, and the joint is at zero in the step before each new instance's first command.
local RESTARTS = [[
process main() {
  supervision { strategy one_for_one; intensity 5 in 10 s; restart on aborted; }
  instantiated_processes {
    ctrl instof JointSetpoint("arm", "elbow_joint", 3.0, 0.01, "velocity", 0.5, 0.3);
    stop instof Timer("arm", 1.05);
  }
  internal_event_actions { ctrl # stop }
}
]]

suite:case("a_restart_never_overlaps_its_old_instance_on_an_actuator", function()
  local out, trace = run_traced(RESTARTS)
  T.contains(out, "main.ctrl: restarted 3/5 in 10 s")
  local ticks, changes, velocity, last_tick, last_n = {}, {}, {}, nil, nil
  for line in T.read(trace):gmatch("[^\n]+") do
    T.ok(not line:find(" W world.", 1, true), "no sample refused: " .. line)
    local t, n = line:match("^(%d+) D main%.ctrl%.Cmd n=(%d+) ")
    if t then
      t, n = tonumber(t), tonumber(n)
      -- a new instance counts from 1 again; one instance may write twice in a tick (its last command, its zero)
      if last_n and n <= last_n then
        T.ok(t > last_tick, sformat("two instances wrote at tick %d", t))
        changes[#changes + 1] = { old = last_tick, new = t }
      end
      ticks[#ticks + 1], last_tick, last_n = t, t, n
    end
    local vt, v = line:match("^(%d+) D world%.joint%.elbow_joint%.velocity n=%d+ digest=%d+ value=%[(.-)%]")
    if vt then velocity[tonumber(vt)] = tonumber(v) end
  end
  T.eq(#changes, 3, "three restarts in the trace")
  for _, c in ipairs(changes) do
    T.eq(velocity[c.new], 0, sformat("the joint at zero before the instance of %d wrote (the old one's last: %d)",
                                     c.new, c.old))
  end
end)

return suite:run(...)
