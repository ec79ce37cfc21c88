-- `dca run --blackbox BEFORE,AFTER` (docs/recording.md, "Black box"): the door run with its handle jammed
-- aborts at a tick a full recording shows; the black box of the same run writes one file that names that
-- trigger and holds exactly the full recording's messages of [t - before, t + after], the run's lines included.
-- The root aborts at that same tick. Time holds there while the tree stops; with a black box the world alone then
-- runs on to the end of its window (run.lua, Run:after_the_end), so the file reaches exactly t + after. The full
-- recording ends at the end's tick: the exact comparison stops there; the C++ test (tests/sim/blackbox_test.cpp)
-- checks a whole window.
local T = require "dca.testing"
local suite = T.suite("blackbox")

local dca, src = T.exe, T.src
local core = require "dca.core"
local system = src .. "/worlds/door/systems/door_open.dca"

local function run(args)
  return T.sh("timeout 600 " .. dca .. " run " .. system .. " --quiet --sim door --world-opt jammed " .. args)
end

-- The messages of `rec` by topic, as "T DATA" texts, those in [from, to] ns (the lines' own channel aside).
local function window(rec, from, to, skip)
  local out = {}
  for _, m in ipairs(rec.messages) do
    local topic = rec.channels[m.channel].topic
    if m.t >= from and m.t <= to and not skip[topic] then
      out[topic] = out[topic] or {}
      table.insert(out[topic], m.t .. " " .. m.data)
    end
  end
  return out
end

suite:case("a_fault_writes_the_window_of_the_full_recording_around_it", function()
  local full, box = T.tmpname(".mcap"), T.tmpname(".mcap")
  local out, rc = run("--record " .. full .. " --record-ports all")
  T.eq(rc, 1, "the jammed door aborts:\n" .. out)
  out, rc = run("--record " .. box .. " --record-ports all --blackbox 1,0.5 --record-compression lz4")
  T.eq(rc, 1, "the jammed door aborts:\n" .. out)
  T.contains(out, "black box, 1 written")
  local file = box:gsub("%.mcap$", "-1.mcap")
  -- the black box's file, lz4 chunks (the full recording's: zstd), read by @mcap/core too (tests/mcap)
  local node_out, node_rc = T.sh("node " .. src .. "/tests/mcap/read_mcap.mjs " .. file .. " --compression lz4")
  T.eq(node_rc, 0, "@mcap/core reads the black box:\n" .. node_out)
  local f = assert(core.mcap_read(full))
  local b = assert(core.mcap_read(file))
  -- the fault's tick: the full recording's first aborted line
  local t_fault, t_end
  for _, m in ipairs(f.messages) do
    if f.channels[m.channel].topic == "/dca/events" and m.data:find('"state":"aborted"', 1, true) then
      t_fault = t_fault or m.t
    end
    if f.channels[m.channel].topic == "/dca/events" and m.data:find('"state":"ABORTED"', 1, true) then
      t_end = t_end or m.t
    end
  end
  T.ok(t_fault, "an aborted line in the full recording")
  local trigger
  for _, m in ipairs(b.messages) do
    if b.channels[m.channel].topic == "/dca/blackbox" then trigger = trigger or m end
  end
  T.ok(trigger, "the trigger on /dca/blackbox")
  T.eq(trigger.t, t_fault, "the trigger's tick")
  T.contains(trigger.data, "aborted")
  local from, to = t_fault - 1000000000, math.min(t_fault + 500000000, t_end - 1)
  local skip = { ["/dca/blackbox"] = true, ["/dca/events"] = true, ["/dca/log"] = true }
  T.eq(window(b, from, to, skip), window(f, from, to, skip), "the full recording's window")
  -- the run's lines: those before the fault's tick as the full recording's, and the fault's own
  local lines, want = window(b, from, t_fault - 1, {})["/dca/events"], window(f, from, t_fault - 1, {})["/dca/events"]
  T.eq(lines, want, "the run's lines before the fault")
  local at = window(b, t_fault, t_fault, {})["/dca/events"]
  T.ok(at and table.concat(at, "\n"):find("presshandle: aborted", 1, true), "the fault's line")
  local last = 0
  for _, m in ipairs(b.messages) do last = math.max(last, m.t) end
  T.eq(last, t_fault + 500000000, "messages after the trigger, up to t + after")
  local full_last = 0
  for _, m in ipairs(f.messages) do full_last = math.max(full_last, m.t) end
  T.eq(full_last, t_end, "the full recording ends at the run's end")
  T.ok(b.messages[1] and f.messages[1], "both hold messages")
  for _, x in ipairs({ full, box, file }) do os.remove(x) end
end)

-- A robot's command input (docs/safety.md): two writers on one joint, and one writer far past its limit.
local ur10 = src .. "/worlds/ur10/ur10.urdf"
local TWO_WRITERS = T.read(src .. "/tests/lua/launch/systems/two_writers.dca")
local FAR = [[
process main() {
  instantiated_processes {
    far   instof JointSetpoint("arm", "elbow_joint", 10.0, 0.01);
    limit instof Deadline("arm", 1);
  }
  internal_event_actions { far # limit }
}
]]

-- `file` run on the mock UR10 with `args`. --> its output, exit code
local function robot_run(file, args)
  return T.sh("timeout 120 " .. dca .. " run " .. file .. " --quiet --sim mock:" .. ur10 .. " " .. args)
end

-- The black box's trigger message of `rec`, and the tick of the run's end (its first outcome line).
local function trigger_and_end(rec)
  local trigger, t_end
  for _, m in ipairs(rec.messages) do
    local topic = rec.channels[m.channel].topic
    if topic == "/dca/blackbox" then trigger = trigger or m end
    if topic == "/dca/events" and not t_end and m.data:find('"state":"[A-Z]+"') then t_end = m.t end
  end
  return trigger, t_end
end

-- The first black box of a run of `file` against its full recording: the trigger names `why` at tick `t`
-- (nil: the trigger's own) and the file holds exactly the full recording's messages of [t - 0.5, t + 0.2]
-- (up to the run's end). --> the trigger's tick
local function box_equals_full(dir, file, why, t)
  local full, box = dir .. "/full.mcap", dir .. "/box.mcap"
  local out, rc = robot_run(file, "--record " .. full)
  T.ok(rc == 0 or rc == 1, "the full recording:\n" .. out)
  out, rc = robot_run(file, "--record " .. box .. " --blackbox 0.5,0.2")
  T.ok(rc == 0 or rc == 1, "the black box:\n" .. out)
  local f, b = assert(core.mcap_read(full)), assert(core.mcap_read(dir .. "/box-1.mcap"))
  local trigger = trigger_and_end(b)
  local _, t_end = trigger_and_end(f)
  T.ok(trigger and t_end, "a trigger and the run's end")
  T.contains(trigger.data, why)
  if t then T.eq(trigger.t, t, "the trigger's tick") end
  local from, to = math.max(0, trigger.t - 500000000), math.min(trigger.t + 200000000, t_end - 1)
  local skip = { ["/dca/blackbox"] = true, ["/dca/events"] = true, ["/dca/log"] = true }
  T.eq(window(b, from, to, skip), window(f, from, to, skip), "the full recording's window")
  return trigger.t
end

suite:case("a_second_writer_triggers_the_black_box_at_its_first_refusal", function()
  local dir = T.tmpdir()
  T.write(dir .. "/two.dca", TWO_WRITERS)
  -- the first refusal's tick, from the trace
  local out, rc = robot_run(dir .. "/two.dca", "--trace " .. dir .. "/run.trace")
  T.eq(rc, 0, out)
  local first = tonumber(T.read(dir .. "/run.trace"):match("(%d+) W world%.joint%.elbow_joint%.position_command refused="))
  T.ok(first, "a refusal in the trace")
  box_equals_full(dir, dir .. "/two.dca", "a second writer on joint.elbow_joint.position_command: main.", first)
end)

suite:case("a_storm_of_limit_clamps_triggers_the_black_box_once", function()
  local dir = T.tmpdir()
  T.write(dir .. "/far.dca", FAR)
  local t = box_equals_full(dir, dir .. "/far.dca", "a storm of limit clamps: 10 within 1 s")
  -- the storm's tick: the world's clamp count reaches 10 between its records before and after it
  local f = assert(core.mcap_read(dir .. "/full.mcap"))
  local before, after
  for _, m in ipairs(f.messages) do
    if f.channels[m.channel].topic == "/world/safety/clamps" then
      local n = 0  -- the clamps of every command input
      for x in m.data:gmatch("[%d.]+") do n = n + tonumber(x) end
      if m.t < t then before = n elseif not after then after = n end
    end
  end
  T.ok(before and before < 10 and after and after >= 10, "10 clamps reached at the trigger: " .. tostring(before)
    .. ", " .. tostring(after))
  -- one storm, one file: the clamps go on for the whole second at 100 a second, the storm is not triggered
  -- again; the second file is the deadline's abort
  T.ok(not io.open(dir .. "/box-3.mcap"), "one file for the storm, one for the deadline's abort")
  T.contains(T.mcap_text(dir .. "/box-2.mcap"), "aborted")
  -- 10 clamps within 50 ms are no storm at one clamped sample every 10 ms
  local out = robot_run(dir .. "/far.dca", "--record " .. dir .. "/again.mcap --blackbox 0.5,0.2 --blackbox-storm 10,0.05")
  T.contains(out, "black box, 1 written")
  T.ok(not T.mcap_text(dir .. "/again-1.mcap"):find("storm", 1, true), "no storm:\n" .. out)
end)

-- A crash and an escalation are faults (docs/recording.md, "Black box" 7): a leaf that dies by SIGSEGV every
-- 0.5 s of simulated time, under `intensity 1 in 10 s`, is restarted once, then its group gives up. The first
-- crash writes box-1.mcap. The second crash, the escalation it causes and the group's ABORTED all come at 1 s:
-- one file or several (a line that reaches the world after its file was written starts a new one: time runs on
-- while the tree stops), each trigger named on /dca/blackbox at its line's tick, in a file of [0.7, 1.2] s.
local ESCALATES = [[
process main() {
  supervision { strategy one_for_one; intensity 1 in 10 s; }
  instantiated_processes {
    crashy instof Crash("arm", 50, "segv", 0.01);
    stop instof Timer("arm", 5);
  }
  internal_event_actions { crashy # stop }
}
]]

-- Crash containment under the default placement in simulated time (`host`, docs/placement.md): the crash ends
-- every leaf of the host's shared node, and the outcome names the leaf whose code crashed.
suite:case("in_simulated_time_a_crash_ends_the_hosts_shared_node_and_names_the_leaf_that_crashed", function()
  local dir = T.tmpdir()
  local out, rc = robot_run(T.write(dir .. "/esc.dca", ESCALATES), "")
  T.eq(rc, 1, "the run ends ABORTED:\n" .. out)
  T.contains(out, "main: ABORTED at main.crashy: restart intensity 1 in 10 s exceeded; last: crashy killed by "
    .. "SIGSEGV on host arm (shared node leaves:main@arm#")
  T.ok(out:find("leaves:main@arm#%d+, 2 leaves; it crashed in main%.crashy%)") ~= nil, out)
end)

suite:case("a_crash_and_an_escalation_trigger_the_black_box", function()
  local dir = T.tmpdir()
  -- one process per leaf: the crash ends crashy alone (in simulated time the default shares a host's node)
  local out, rc = robot_run(T.write(dir .. "/esc.dca", ESCALATES),
    "--placement process --record " .. dir .. "/box.mcap --blackbox 0.3,0.2")
  T.eq(rc, 1, "the run ends ABORTED:\n" .. out)
  T.contains(out, "box-1.mcap: main.crashy: exited: killed by SIGSEGV on host arm at 0.500 s, [0.200, 0.700] s")
  T.contains(out, "main.crashy: exited: killed by SIGSEGV on host arm at 1.000 s, [0.700, 1.200] s")
  local exceeded = "restart intensity 1 in 10 s exceeded; last: crashy killed by SIGSEGV on host arm"
  -- every trigger of every file, with its tick, and the tick of the line it names in that file
  local named = {}
  for n = 1, 8 do
    local b = core.mcap_read(dir .. "/box-" .. n .. ".mcap")
    if not b then break end
    local lines = {}
    for _, m in ipairs(b.messages) do
      if b.channels[m.channel].topic == "/dca/events" then lines[core.json_decode(m.data).line] = m.t end
    end
    for _, m in ipairs(b.messages) do
      if b.channels[m.channel].topic == "/dca/blackbox" then
        local v = core.json_decode(m.data)
        T.eq(m.t, lines[v.trigger], "the trigger at its line's tick: " .. v.trigger)
        named[v.trigger] = m.t
      end
    end
  end
  T.eq(named["main: " .. exceeded], 1000000000, "the escalation named, at 1 s")
  T.eq(named["main.crashy: exited: killed by SIGSEGV on host arm"] ~= nil, true)
  T.eq(named["main: aborted (main.crashy: " .. exceeded .. ")"], 1000000000)
end)

-- --record-compression and --record-split are checked before anything starts.
suite:case("record_compression_and_split_are_checked_before_the_start", function()
  local base = dca .. " run " .. system .. " --sim door --record " .. T.tmpname(".mcap")
  local out, rc = T.sh(base .. " --record-compression gzip")
  T.eq(rc, 2, out)
  T.contains(out, "--record-compression is zstd, lz4 or none, not 'gzip'")
  out, rc = T.sh(base .. " --record-split 10parsecs")
  T.eq(rc, 2, out)
  T.contains(out, "--record-split needs a size (100MB, 1GiB) or a duration (60s, 10min, 1h), not '10parsecs'")
  out, rc = T.sh(base .. " --record-split 60s --blackbox 1,1")
  T.eq(rc, 2, out)
  T.contains(out, "--record-split and --blackbox exclude each other")
  out, rc = T.sh(dca .. " run " .. system .. " --sim door --record-compression lz4")
  T.eq(rc, 2, out)
  T.contains(out, "--record-compression and --record-split go with --record FILE.mcap")
  out, rc = T.sh(dca .. " sim --record-split 100 --record x.mcap")
  T.eq(rc, 2, out)
  T.contains(out, "--record-split needs a size (100MB, 1GiB: at least 4096 bytes)")
end)

-- --profile (the MCAP ros2 profile, docs/recording.md) is checked before anything starts: exit code 2 and why.
suite:case("record_profile_is_checked_before_the_start", function()
  for cmd, why in pairs({
    [" run " .. system .. " --sim door --record " .. T.tmpname(".mcap") .. " --profile ros1"] =
      "--profile is ros2, not 'ros1'",
    [" run " .. system .. " --sim door --profile ros2"] = "--profile goes with --sim WORLD and --record FILE.mcap",
    [" sim --record-profile ros1 --record x.mcap"] = "--record-profile needs ros2",
  }) do
    local out, rc = T.sh(dca .. cmd)
    T.eq(rc, 2, out)
    T.contains(out, why)
  end
end)

suite:case("a_black_box_needs_an_mcap_recording", function()
  local out, rc = T.sh(dca .. " run " .. system .. " --sim door --blackbox 1,1")
  T.eq(rc, 2, "exit code")
  T.contains(out, "--blackbox goes with --record FILE.mcap")
end)
return suite:run(...)
