-- `dca run`: the options that go with --sim WORLD are refused without it, naming the rule; configuration
-- values that are code are refused before anything starts.
local T = require "dca.testing"
local suite = T.suite("run")

local dca, src = T.exe, T.src

for _, c in ipairs({ { "world-opt jammed", "--seed and --world-opt go with --sim WORLD" },
                    { "record x.csv", "--record FILE.csv goes with --sim WORLD" },
                    { "record x.mcap --record-ports all", "--record-ports goes with --sim WORLD: on the wall clock" },
                    { "record x.mcap --blackbox 1,1", "--blackbox goes with --sim WORLD" },
                    { "realtime", "--realtime goes with --sim WORLD" },
                    { "tick-timeout 5000", "--tick-timeout goes with --sim WORLD" },
                    { "spin auto", "--spin goes with --sim WORLD" },
                    { "world-host vision", "--world-host goes with --sim WORLD" },
                    { "as-fast-as-possible", "--as-fast-as-possible goes with --monitor and --sim WORLD" },
                    { "monitor-taps all", "--monitor-taps goes with --monitor and is all or picked, not 'all'" },
                    { "monitor --monitor-taps some", "--monitor-taps goes with --monitor and is all or picked, not 'some'" } }) do
  suite:case("run_" .. c[1]:gsub("[^%w]+", "_") .. "_needs_sim", function()
    local out, rc = T.sh(dca .. " run " .. src .. "/worlds/door/systems/door_open.dca --" .. c[1])
    T.eq(rc, 2, "exit code")
    T.contains(out, c[2])
  end)
end

-- --world-host names a host of the system, checked before anything starts.
suite:case("run_world_host_not_a_host_of_the_system", function()
  local out, rc = T.sh(dca .. " run " .. src .. "/worlds/door/systems/door_open.dca --sim door --world-host lab")
  T.eq(rc, 2, "exit code\n" .. out)
  T.contains(out, "--world-host lab is not a host of " .. src .. "/worlds/door/systems/door_open.dca (manipulation, "
    .. "platform, vision)")
  T.eq(out:find("daemon at", 1, true), nil, "nothing started")
end)

-- Configuration values are data. A defaults file or a --set whose value is code fails the run at
-- once with the value's file:line:col (or column) and starts nothing; on main they were executed (a loop hung
-- the run after its daemons had started). Each run is bounded by `timeout`: a hang is exit code 124.
-- Daemons a failing run left behind (named in its output) are stopped, the logs it kept removed.
local function run_bounded(args)
  local out, rc = T.sh("timeout 20 " .. dca .. " run " .. args)
  for pid in out:gmatch("daemon at %S+ %(pid (%d+)%)") do os.execute("kill " .. pid .. " 2>/dev/null") end
  T.kept_logs(out)  -- (a failed run keeps its daemons' logs)
  return out, rc
end

suite:case("executable_config_values_fail_the_run_at_their_position_and_start_nothing", function()
  local dir = T.tmpdir()
  local system = dir .. "/test_config.dca"
  T.write(system, T.read(src .. "/scripts/systems/test_config.dca"))
  local defaults = T.write(dir .. "/test_config.config",
    "test.wait = 0.5\ntest.threshold = 1.0\nx = (function() while true do end end)()\n")
  local out, rc = run_bounded(system)
  T.eq(rc, 2, "exit code (124: the value ran and hung)\n" .. out)
  T.contains(out, defaults .. ":3:5: the value of x is not a literal")
  T.contains(out, "found '('")
  T.ok(not out:find("daemon at", 1, true) and not out:find("starting", 1, true), "nothing started:\n" .. out)
  os.remove(defaults)
  for _, c in ipairs({ { "x=os.exit(3)", "column 3: 'os' is not a value" },
                       { "x=(function() while true do end end)()", "column 3: " } }) do
    out, rc = run_bounded(system .. " --set '" .. c[1] .. "'")
    T.eq(rc, 2, c[1] .. ": exit code (124: the value ran and hung)\n" .. out)
    T.contains(out, "--set: " .. c[1] .. ": " .. c[2])
    T.ok(not out:find("daemon at", 1, true) and not out:find("starting", 1, true), "nothing started:\n" .. out)
  end
  os.remove(system)
  os.remove(dir)
end)

-- A connection whose types cannot meet fails `dca run` before anything starts, at its file:line:col (it used to
-- fail only when the node refused the link, after the start).
suite:case("a_port_type_mismatch_fails_the_run_before_anything_starts", function()
  local system = T.tmpfile([[process main() {
  instantiated_processes { three instof Constant("h", 0.01, 1, 2, 3); level instof Threshold("h", 1); }
  internal_connections(level, run) { three, Out -> level, In; }
  internal_event_actions { level[run] # three }
}
]])
  local out, rc = run_bounded(system)
  T.eq(rc, 2, "exit code\n" .. out)
  T.contains(out, system .. ":3:38: main.three.Out (vectorx of size 3) cannot feed main.level.In (scalar)")
  T.ok(not out:find("daemon at", 1, true) and not out:find("starting", 1, true), "nothing started:\n" .. out)
  os.remove(system)
end)

-- A crash loop under a supervision policy ends by escalation: `dca run` shows each restart with its
-- count, the group giving up, and exits 1 with the root's ABORTED naming the crash.
suite:case("a_crash_loop_ends_by_escalation_with_counts_and_the_first_cause", function()
  local out, rc = run_bounded(src .. "/scripts/systems/test_crash_loop.dca")
  T.eq(rc, 1, "exit code")
  for n = 1, 3 do T.contains(out, "main.loop.crashy: restarted " .. n .. "/3 in 60 s (pid ") end
  T.contains(out, "main.loop: restart intensity 3 in 60 s exceeded; last: crashy killed by SIGSEGV on host h1")
  T.contains(out, "main: ABORTED at main.loop.crashy: restart intensity 3 in 60 s exceeded; last: crashy killed by "
    .. "SIGSEGV on host h1")
end)

-- Watched live (--monitor), simulated time is paced to the wall clock unless --as-fast-as-possible: with
-- --realtime it asks for opposite things.
suite:case("as_fast_as_possible_and_realtime_exclude_each_other", function()
  local out, rc = T.sh(dca .. " run " .. src .. "/worlds/door/systems/door_open.dca --sim door --monitor "
    .. "--as-fast-as-possible --realtime")
  T.eq(rc, 2, "exit code")
  T.contains(out, "--as-fast-as-possible and --realtime exclude each other")
end)

return suite:run(...)
