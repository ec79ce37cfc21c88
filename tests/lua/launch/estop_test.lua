-- The emergency stop (docs/safety.md, "Emergency stop"): pressed mid-run at a fixed tick of simulated time by a
-- button leaf (the world's `estop` input), every actuator reads zero from the next tick; the supervisors see the
-- press with its source; a release that does not name it is refused, and so is one while the button is held;
-- release("estop") in the REPL then resumes the run to DONE; and the trace of two runs is the same, byte for
-- byte. SIGUSR1 to `dca run` presses it too (and triggers the black box), the REPL of `dca repl` releases it,
-- and the run's summary says both; on a driver, the press stops the driver and the release runs it again.
local T = require "dca.testing"
local suite = T.suite("estop")

local dca, src = T.exe, T.src
local WORLD = "mock:" .. src .. "/worlds/ur10/ur10.urdf"
local SYSTEM = src .. "/tests/lua/launch/systems/estop.dca"
local JOINTS = { "shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
                 "wrist_3_joint" }

local SCENARIO = [[
local S = require "dca.scenario"
S.backends = { "real" }
local SYSTEM, WORLD, JOINTS = %q, %q, { %s }
local sys = S.system(SYSTEM, { sim = WORLD, seed = 7 })
local function say(line) return sys:repl(line) end
S.step("up and running; time held at 2 s", function()
  sys:up()
  sys:world_hold_when(2.0)
  sys:run()
  sys:world_wait_held(2.0)
end)
S.step("the button latched the stop; every joint is at rest; the root saw it with its source", function()
  local st = sys:world_status()
  S.eq(st.estop.latched, true)
  S.eq(st.estop.source, "input")
  S.ok(st.estop.held_samples > 0, "the leaves' samples still came: " .. tostring(st.estop.held_samples))
  for _, j in ipairs(JOINTS) do S.eq(sys:world_read("joint." .. j .. ".velocity")[1], 0, j) end
  S.eq(#sys:lines_matching("^main: emergency stop pressed by input at 1%%.0%%d%%d s$"), 1)
  S.eq(sys:state("main.wrist"), "running")
end)
S.step("a release must name it, and is refused while the button is still held", function()
  S.contains(say("release('brakes')"), "name what to release")
  S.contains(say("release()"), "name what to release")
  S.contains(say("release('estop')"), "the emergency stop's input world.estop still reads pressed")
  S.eq(sys:world_status().estop.latched, true)
end)
S.step("the button let go: release('estop') in the REPL at 3 s resumes, both joints reach their targets", function()
  sys:world_hold_at(3.0)
  S.contains(say("release('estop')"), "emergency stop released at 3.000 s")
  S.contains(say("release('estop')"), "not pressed")
  sys:world_go()
  local out = sys:wait_outcome(60)
  S.eq(out.type, "done")
  S.eq(#sys:lines_matching("^main: emergency stop released by REPL at 3%%.000 s$"), 1)
end)
return S.finish()
]]

-- Runs the scenario with its trace to `trace`. --> output, rc
local function run(dir, trace)
  local quoted = {}
  for i, j in ipairs(JOINTS) do quoted[i] = string.format("%q", j) end
  local file = T.write(dir .. "/estop.lua", string.format(SCENARIO, SYSTEM, WORLD, table.concat(quoted, ", ")))
  local out, rc = T.sh("timeout 200 " .. dca .. " scenario --backend real --trace " .. trace .. " " .. file)
  T.kept_logs(out)
  return out, rc
end

suite:case("pressed_at_a_fixed_tick_every_actuator_reads_zero_at_the_next_and_the_trace_repeats", function()
  local dir = T.tmpdir()
  local out, rc = run(dir, dir .. "/a.trace")
  T.eq(rc, 0, "the scenario passes\n" .. out)
  local trace = T.read(dir .. "/a.trace")
  local pressed = trace:match("\n(%d+) E world%.estop pressed by=input\n")
  T.ok(pressed, "the press is in the trace at its tick")
  T.ok(trace:find("\n3000000000 E world.estop released by=REPL\n", 1, true), "the release at 3 s")
  -- the world's outputs at the ticks after the press: every joint's velocity 0 from the first
  local after, seen = nil, {}
  for tick, line in trace:gmatch("\n(%d+) ([^\n]*)") do
    local n = tonumber(tick)
    if n > tonumber(pressed) and n < 3000000000 then
      after = after or n
      local j, v = line:match("^D world%.joint%.([%w_]+)%.velocity n=%d+ digest=%d+ value=%[([^%]]+)%]$")
      if j and n == after then seen[j] = tonumber(v) end
      if j then T.eq(tonumber(v), 0, line) end
    end
  end
  for _, j in ipairs(JOINTS) do T.eq(seen[j], 0, j .. " at the first tick after the press") end
  local _, rc2 = run(dir, dir .. "/b.trace")
  T.eq(rc2, 0)
  local diff = T.sh(dca .. " trace diff " .. dir .. "/a.trace " .. dir .. "/b.trace")
  T.ok(T.read(dir .. "/b.trace") == trace, "the trace of a second run is the same:\n" .. diff)
end)

local wait_for = T.wait_for

-- `dca run ARGS` in the background (its output to `log`), up, then SIGUSR1 to it and its press said by the
-- root. --> its pid, the command of a console on its root (`dca repl main ...`)
local function pressed(args, log)
  local pid = T.background(dca .. " run " .. args, log)
  local text = wait_for(log, "whole tree is configured", 60)
  T.ok(text, "dca run came up")
  local root, key = text:match("console: dca repl main %-%-daemon (%S+) %-%-key (%S+)")
  T.ok(root and key, text)
  os.execute("kill -USR1 " .. pid)
  T.ok(wait_for(log, "main: emergency stop pressed by SIGUSR1 at", 30), "the root says the press and its source")
  return pid, string.format("%s repl main --daemon %s --key %s", dca, root, key)
end

-- A joint moving slowly until the REPL ends the run (time paced to the wall clock).
local SLOW = [[
process main() {
  instantiated_processes {
    wrist instof JointSetpoint("arm", "wrist_1_joint", 0.5, 0.01, "velocity", 0.05, 600);
    limit instof Timer("arm", 600);
  }
  internal_event_actions { wrist # limit }
}
]]

suite:case("sigusr1_to_dca_run_presses_it_the_repl_releases_it_and_the_summary_says_both", function()
  local dir = T.tmpdir()
  local log = dir .. "/run.log"
  local pid, repl = pressed(T.write(dir .. "/slow.dca", SLOW) .. " --sim " .. WORLD .. " --realtime --record " .. dir
    .. "/box.mcap --blackbox 1,0.5", log)
  local out, rc = T.sh("printf '%s\n' 'estop()' 'release(\"estop\")' | " .. repl)
  T.eq(rc, 0, out)
  T.contains(out, "emergency stop already pressed by SIGUSR1")
  T.contains(out, "emergency stop released at")
  T.ok(wait_for(log, "main: emergency stop released by REPL at", 30), "the root says the release and its source")
  out, rc = T.sh("printf '%s\n' 'event(\"limit\", \"done\", 1)' | " .. repl)
  T.eq(rc, 0, out)
  T.ok(T.wait_exit(pid, 60), "dca run ended")
  local text = T.read(log)
  T.ok(text:find("\nemergency stop: pressed 1 time, %d+ command samples kept from the robot while latched\n"
    .. "  pressed at [%d.]+ s by SIGUSR1\n  released at [%d.]+ s by REPL\n"), text)
  T.contains(text, "main: DONE")
  T.ok(text:find("box%-1%.mcap: emergency stop by SIGUSR1 at [%d.]+ s"), "the press triggered the black box: " .. text)
end)

-- `blackbox(why)` in the REPL (docs/recording.md, "Black box"): the world's trigger at the tick it arrives; the
-- file names `REPL: why` on /dca/blackbox and in the run's summary.
suite:case("blackbox_in_the_repl_writes_a_file_that_names_its_why", function()
  local dir = T.tmpdir()
  local log = dir .. "/run.log"
  local pid = T.background(dca .. " run " .. T.write(dir .. "/slow.dca", SLOW) .. " --sim " .. WORLD
    .. " --realtime --record " .. dir .. "/box.mcap --blackbox 0.5,0.2", log)
  local text = wait_for(log, "whole tree is configured", 60)
  T.ok(text, "dca run came up")
  local root, key = text:match("console: dca repl main %-%-daemon (%S+) %-%-key (%S+)")
  T.ok(root and key, text)
  local repl = string.format("%s repl main --daemon %s --key %s", dca, root, key)
  local out, rc = T.sh("printf '%s\n' 'blackbox(\"the gripper slipped\")' | " .. repl)
  T.eq(rc, 0, out)
  local t = out:match("black box triggered %(REPL: the gripper slipped%) at ([%d.]+) s")
  T.ok(t, "the REPL says the trigger and its tick:\n" .. out)
  out, rc = T.sh("printf '%s\n' 'event(\"limit\", \"done\", 1)' | " .. repl)
  T.eq(rc, 0, out)
  T.ok(T.wait_exit(pid, 60), "dca run ended")
  text = T.read(log)
  T.contains(text, "box-1.mcap: REPL: the gripper slipped at " .. t .. " s")
  local rec = assert(require("dca.core").mcap_read(dir .. "/box-1.mcap"))
  local trigger
  for _, m in ipairs(rec.messages) do
    if rec.channels[m.channel].topic == "/dca/blackbox" then trigger = trigger or m end
  end
  T.ok(trigger, "the trigger on /dca/blackbox")
  T.contains(trigger.data, '"trigger":"REPL: the gripper slipped"')
  T.eq(string.format("%.3f", trigger.t / 1e9), t, "at the tick the REPL said")
end)

-- On a driver (--driver, wall clock): the press stops the driver's controller (its halt leaves the robot safe),
-- the release runs it again; the root says both with their sources.
suite:case("on_a_driver_the_press_stops_it_and_the_release_runs_it_again", function()
  local dir = T.tmpdir()
  local file = T.write(dir .. "/wait.dca", [[
process main() {
  instantiated_processes { limit instof Timer("h1", 600); }
  internal_event_actions { limit }
}
]])
  local log = dir .. "/run.log"
  local pid, repl = pressed(file .. " --driver 'Counter(\"h1\", 0.01)'", log)
  local out, rc = T.sh("printf '%s\n' 'estop()' 'release(\"estop\")' 'release(\"estop\")' | " .. repl)
  T.eq(rc, 0, out)
  T.contains(out, "emergency stop already pressed by SIGUSR1")
  T.contains(out, "emergency stop released at")
  T.contains(out, "not pressed")
  T.ok(wait_for(log, "main: emergency stop released by REPL at", 30), "the root says the release")
  T.sh("printf '%s\n' 'event(\"limit\", \"done\", 1)' | " .. repl)
  T.ok(T.wait_exit(pid, 60), "dca run ended")
  local text = T.read(log)
  T.contains(text, "main: DONE")
  T.ok(not text:find("the robot process was lost", 1, true), text)
end)

return suite:run(...)
