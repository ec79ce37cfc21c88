-- `dca run`, `dca scenario`, `dca supervise`, `dca repl` as a person calls them: usage, check errors first.
local T = require "dca.testing"
local suite = T.suite("supervisor_cli")

local dca, src = T.exe, T.src

local tmpfile = T.tmpfile

-- Processes whose command line mentions `needle` (the test's own temp file name makes it unique).
local function procs_with(needle)
  local ls = io.popen("ls /proc")
  local n = 0
  for pid in ls:lines() do
    if pid:match("^%d+$") then
      local f = io.open("/proc/" .. pid .. "/cmdline", "rb")
      local cmd = f and f:read("a") or ""
      if f then f:close() end
      if cmd:find(needle, 1, true) then n = n + 1 end
    end
  end
  ls:close()
  return n
end

suite:case("run_with_check_errors_prints_file_line_col_and_starts_nothing", function()
  local path = tmpfile([[
process main() {
  instantiated_processes { a instof Timer("h1", 1); }
  internal_event_actions { a # nosuch }
}
]])
  local out, rc = T.sh(dca .. " run " .. path)
  T.eq(rc, 2)
  T.contains(out, path .. ":3:")
  T.contains(out, "nosuch")
  T.eq(procs_with(path), 0, "no process started for " .. path)
  os.remove(path)
end)

suite:case("run_without_a_file_prints_usage_and_exits_2", function()
  for args, says in pairs({ [""] = "usage: dca run FILE.dca", [" x.dca --frob"] = "unknown option '--frob'" }) do
    local out, rc = T.sh(dca .. " run" .. args)
    T.eq(rc, 2, "dca run" .. args)
    T.contains(out, says)
  end
end)

suite:case("run_with_a_bad_hosts_file_names_its_line", function()
  local hosts = tmpfile("# hosts\nh1 127.0.0.1:1\nthis line is wrong\n", ".hosts")
  local out, rc = T.sh(dca .. " run " .. src .. "/scripts/systems/test_reload.dca --hosts " .. hosts)
  T.eq(rc, 2)
  T.contains(out, hosts .. ":3:1: expected 'name address'")
  os.remove(hosts)
end)

suite:case("scenario_reports_each_step_and_fails_with_the_failing_step", function()
  local path = tmpfile([[
local S = require "dca.scenario"
local sys = S.system(require("dca.testing").src .. "/scripts/systems/test_reload.dca")
S.step("up", function() sys:up() end)
S.step("expects DONE but the deadline wins", function()
  sys:run()
  S.eq(sys:wait_outcome(5).type, "done")
end)
S.step("never reached", function() end)
return S.finish()
]], ".lua")
  local out, rc = T.sh(dca .. " scenario " .. path)
  os.remove(path)
  T.eq(rc, 1)
  T.contains(out, "ok   1 up (t=0.000)")
  T.contains(out, "FAIL 2 expects DONE but the deadline wins (t=1.000)")
  T.contains(out, "expected \"done\"")
  T.ok(not out:find("never reached", 1, true), "steps after a failure do not run")
  T.contains(out, "2 steps, 1 failed")
end)

suite:case("supervise_and_repl_need_their_arguments", function()
  local out, rc = T.sh(dca .. " supervise --name x")
  T.ok(rc == 2 or rc == 3, "rc " .. tostring(rc))
  T.ok(out:find("--daemon", 1, true) or out:find("control plane", 1, true), out)
  out, rc = T.sh(dca .. " repl")
  T.ok(rc == 2 or rc == 3)
end)

local wait_for = T.wait_for

suite:case("a_console_opens_on_a_sub_supervisor_and_on_the_root_while_the_system_runs", function()
  local path = tmpfile([[
process G(h) {
  host { h }
  instantiated_processes { t instof Threshold(h, 1); n instof Counter(h, 0.01); }
  internal_event_actions { t, n }
}
process main() {
  instantiated_processes { g instof G("h2"); w instof Timer("h1", 600); }
  internal_event_actions { g # w }
}
]])
  local log = path .. ".log"
  local pid = T.background(dca .. " run " .. path, log)
  local text = wait_for(log, "whole tree is configured", 60)
  T.ok(text, "dca run came up")
  local h2 = text:match("host h2: daemon at (%S+)")
  local key = text:match("%-%-key (%S+)")
  T.ok(h2 and key, text)
  -- the sub-supervisor main.g (a `dca supervise` on h2) takes a console beside its parent
  local out, rc = T.sh(string.format("printf 'tree()\nstatus(\"main.g.t\")\n' | %s repl main.g --daemon %s --key %s",
    dca, h2, key))
  T.eq(rc, 0, out)
  T.contains(out, "Threshold@h2")
  T.contains(out, "running")
  -- the configuration repository of the supervisor's host (h2), from its console
  out, rc = T.sh(string.format("printf '%%s\n' 'config.set(\"door.width\", 0.9)' 'config.get(\"door.width\")' "
    .. "'config.list(\"door\")' 'config.log(1)' 'config.get(\"door.widht\")' | %s repl main.g --daemon %s --key %s",
    dca, h2, key))
  T.eq(rc, 0, out)
  T.contains(out, "set 1 key: transaction")
  T.contains(out, "\n0.9\n")
  T.contains(out, "door.width = 0.9")
  T.contains(out, "(host h2,")
  T.contains(out, "unknown key 'door.widht' (did you mean door.width?)")
  -- a leaf's port and timers, asked of its node
  out, rc = T.sh(string.format("printf '%%s\n' 'read(\"n\", \"Count\")' 'stats(\"n\")' 'read(\"t\", \"Nope\")' "
    .. "'stats(\"main.g\")' | %s repl main.g --daemon %s --key %s", dca, h2, key))
  T.eq(rc, 0, out)
  T.ok(out:find("%(%d+ samples%)"), "read gives the value and a count:\n" .. out)
  T.contains(out, "main.g.n (wall clock):\n  main.g.n every 10.000 ms: ")
  T.contains(out, "overruns ")
  T.contains(out, "main.g.t: no port 'Nope' on main.g.t; ports are: In")
  T.contains(out, "main.g is a group: stats asks a leaf")
  -- the root, at the address dca run printed
  local root = text:match("console: dca repl main %-%-daemon (%S+)")
  out, rc = T.sh(string.format("printf 'tree()\n' | %s repl main --daemon %s --key %s", dca, root, key))
  T.eq(rc, 0, out)
  T.contains(out, "Timer@h1")
  os.execute("kill -INT " .. pid)
  T.ok(wait_for(log, "interrupted", 10), "dca run stops on SIGINT")
  T.ok(T.wait_exit(pid, 60), "dca run exited")
  os.remove(path) os.remove(log)
end)

-- A laser on the robot (a device port: laser.range) until a Timer ends the run after 0.5 s.
local LASER = src .. "/tests/lua/cli/systems/laser_until_timer.dca"

suite:case("run_sim_starts_the_world_wires_device_ports_stamps_simulated_time_and_summarises", function()
  local out, rc = T.sh(dca .. " run " .. LASER .. " --sim door --seed 1")
  T.eq(rc, 0, out)
  T.contains(out, "world: ready")
  T.contains(out, "main: 1 device ports wired to the world")
  T.ok(out:find("%[sim +0%.000%] main%.laser: running"), "lines carry the simulated time:\n" .. out)
  T.ok(out:find("door opened to %-?%d+%.%d deg"), out)
  local simulated = tonumber(out:match("simulated (%d+%.%d+) s in"))
  T.ok(simulated and simulated >= 0.5, "simulated time: " .. tostring(simulated))
  -- the steps with their simulated start and end: the Timer ran its 0.5 s of simulated time
  local a, b = out:match("(%d+%.%d+) %-  *(%d+%.%d+)  main%.stop  done")
  T.ok(a and b, "a step line for main.stop:\n" .. out)
  -- time stood at 0 until the root ran; a stamp is the world's time at or after the event (exact when the
  -- node's event carries its own time), so the Timer's end is never before its 0.5 s of simulated time
  T.eq(tonumber(a), 0)
  T.ok(tonumber(b) >= 0.5 - 1e-9, "0.5 s of simulated time at least: " .. a .. " - " .. b)
  T.ok(out:find("main%.laser  stopped"), out)
end)

-- A group disabled by `#` while it runs (issue 32): the summary's step says "stopped", not "aborted".
local GROUP_STOPPED = [[
process Scan() {
  instantiated_processes { laser instof LaserSensor("h1"); }
  internal_event_actions { laser }
}
process main() {
  instantiated_processes {
    scan instof Scan();
    stop instof Timer("h2", 0.5);
  }
  internal_event_actions { stop # scan }
}
]]

suite:case("a_group_disabled_by_hash_is_stopped_in_the_summary", function()
  local path = tmpfile(GROUP_STOPPED)
  local out, rc = T.sh(dca .. " run " .. path .. " --sim door --seed 1")
  T.eq(rc, 0, out)
  T.ok(out:find("%d+%.%d+  main%.scan  stopped\n"), "main.scan's step is stopped:\n" .. out)
  T.ok(not out:find("main%.scan: aborted"), "no aborted line for main.scan:\n" .. out)
  T.ok(out:find("%d+%.%d+  main%.scan%.laser  stopped"), out)
  os.remove(path)
end)

-- A Timer on h2 whose seconds come from the configuration repository (the root's defaults are written on h1's
-- replica: h2's must have them before the start); the step's end in simulated time shows the value used.
local CONFIGURED = [[
process main() {
  instantiated_processes {
    laser instof LaserSensor("h1");
    stop  instof Timer("h2", config("test.wait"));
  }
  internal_event_actions { stop # laser }
}
]]

local function timer_end(out)
  local a, b = out:match("(%d+%.%d+) %-  *(%d+%.%d+)  main%.stop  done")
  return tonumber(b)
end

suite:case("run_reads_config_parameters_from_the_defaults_file_and_set_and_keeps_them_in_a_state_dir", function()
  local path = tmpfile(CONFIGURED)
  local defaults = path:gsub("%.dca$", ".config")
  local f = assert(io.open(defaults, "w"))
  f:write("# the Timer's wait\ntest.wait = 0.3\n")
  f:close()
  -- the defaults file beside the system
  local out, rc = T.sh(dca .. " run " .. path .. " --sim door")
  T.eq(rc, 0, out)
  T.contains(out, "config: " .. defaults .. ": 1 key seeded, 0 already set (on host h1, replicated to h2)")
  local t = timer_end(out)
  T.ok(t and t >= 0.3 - 1e-9 and t < 0.45, "the Timer waited test.wait = 0.3 s: " .. tostring(t) .. "\n" .. out)
  -- --set wins over the defaults; a state dir keeps the repository for the next run, whose defaults then
  -- do not overwrite it
  local state = T.tmpname()
  out, rc = T.sh(dca .. " run " .. path .. " --sim door --state-dir " .. state .. " --set test.wait=0.6")
  T.eq(rc, 0, out)
  T.contains(out, "0 keys seeded, 0 already set; 1 key set")
  t = timer_end(out)
  T.ok(t and t >= 0.6 - 1e-9 and t < 0.75, "--set test.wait=0.6: " .. tostring(t) .. "\n" .. out)
  out, rc = T.sh(dca .. " run " .. path .. " --sim door --state-dir " .. state)
  T.eq(rc, 0, out)
  T.contains(out, "0 keys seeded, 1 already set")
  t = timer_end(out)
  T.ok(t and t >= 0.6 - 1e-9 and t < 0.75, "the kept repository's 0.6: " .. tostring(t) .. "\n" .. out)
  T.ok(io.open(state .. "/h2/config.db", "r") ~= nil, "h2's replica is in the state dir")
  os.execute("rm -rf " .. state)
  os.remove(path)
  os.remove(defaults)
end)

suite:case("run_with_an_unknown_config_key_or_a_wrong_type_names_process_parameter_and_key_and_starts_nothing", function()
  local path = tmpfile((CONFIGURED:gsub('config%("test.wait"%)', 'config("test.wiat")')))
  local out, rc = T.sh(dca .. " run " .. path .. " --sim door --set test.wait=0.3")
  T.eq(rc, 2, out)
  T.contains(out, "process main.stop on host h2: parameter 1 'seconds' (config key 'test.wiat'): unknown key "
    .. "'test.wiat' (did you mean test.wait?)")
  T.ok(not out:find("starting", 1, true), "nothing started:\n" .. out)
  os.remove(path)
  path = tmpfile(CONFIGURED)
  out, rc = T.sh(dca .. " run " .. path .. " --sim door --set 'test.wait=\"soon\"'")
  T.eq(rc, 2, out)
  T.contains(out, "process main.stop on host h2: parameter 1 'seconds' (config key 'test.wait'): the value \"soon\" "
    .. "is a string, not a number")
  -- a defaults file that is not `key = value` is named with its line and column
  local defaults = path:gsub("%.dca$", ".config")
  local f = assert(io.open(defaults, "w"))
  f:write("test.wait = 0.3\ntest.other 2\n")
  f:close()
  out, rc = T.sh(dca .. " run " .. path .. " --sim door")
  T.eq(rc, 2, out)
  T.contains(out, defaults .. ":2:1: expected `key = value`")
  os.remove(defaults)
  os.remove(path)
end)

suite:case("a_device_leaf_without_a_world_fails_the_start_naming_it_and_its_ports", function()
  local out, rc = T.sh(dca .. " run " .. LASER)
  T.kept_logs(out)
  T.eq(rc, 3, out)
  T.contains(out, "no world for the device ports of main.laser (LaserSensor: Raw <- laser.range)")
  T.contains(out, "--sim")
end)

suite:case("run_sim_with_a_hosts_file_refuses_a_daemon_on_the_wall_clock", function()
  local hosts = require "dca.launch.hosts"
  local key, dir = hosts.fresh_key()
  local set = assert(hosts.start_local({ "h1" }, { exe = dca, key = key, log_dir = dir }))
  local hf = tmpfile("h1 " .. set.hosts.h1 .. "\n", ".hosts")
  local path = tmpfile([[
process main() {
  instantiated_processes { stop instof Timer("h1", 0.2); }
  internal_event_actions { stop }
}
]])
  local out, rc = T.sh("DCA_KEY_FILE=" .. key .. " " .. dca .. " run " .. path .. " --hosts " .. hf .. " --sim door")
  set:stop()
  require("dca.core").remove_tree(dir)
  os.remove(hf) os.remove(path)
  T.eq(rc, 2, out)
  T.contains(out, "the daemon of host h1 runs on the wall clock (start it with --clock sim)")
end)

return suite:run(...)
