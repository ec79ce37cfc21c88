-- Time to add a robot to a running fleet (BENCHMARKS.md format; docs/supervision.md, "A fleet"): real daemons on
-- loopback (base, door and eight robot hosts), wall clock, each step typed in the root's console as a person does.
--
--   RESULT bench=fleet_add_robot variant=group_8_hosts n=.. p50_us=.. ...
--     add_child("robots", "rN") to the robot's Counter running on its host: a `dca supervise` spawned on rN's
--     daemon and configured (its node spawned, registered, wired), then Run down to the leaf (its transition line)
--   RESULT bench=fleet_remove_robot variant=group_8_hosts n=.. ...
--     remove_child("robots_rN") to its answer: the leaf stopped, the subtree shut down, both processes ended
--   RESULT bench=leaf_restart_repl variant=same_host n=.. ...
--     the baseline, alternated with the adds (A B A B): restart("door") typed in the same console, a fresh node of
--     one leaf started, wired and run (what any start of a process pays; an add pays it twice, a supervisor and
--     its leaf)
-- Usage: dca lua tests/bench/fleet_bench.lua [ROUNDS]   (each round adds and removes the eight robots; default 4)
local core = require "dca.core"
local S = require "dca.scenario"
local T = require "dca.testing"
S.backend = "real"
local sformat = string.format

local ROUNDS = tonumber(arg and arg[1]) or 4
local HOSTS = { "r1", "r2", "r3", "r4", "r5", "r6", "r7", "r8" }

local SYSTEM = [[
process Robot(h, period) {
  instantiated_processes { light instof Counter(h, period); }
  internal_event_actions { light }
}
process main() {
  host { "base" }
  supervision { strategy one_for_one; intensity 100 in 1 s; restart on crash, lost; }
  instantiated_processes {
    door instof Counter("door", 0.05);
    robots instances of Robot(0.05) on { "r1", "r2", "r3", "r4", "r5", "r6", "r7", "r8" };
  }
  internal_event_actions { door }
}
]]

local function stats(samples)
  table.sort(samples)
  local n = #samples
  local function q(p) return samples[math.max(1, math.min(n, math.ceil(p * n)))] * 1e6 end
  return sformat("n=%d p50_us=%.0f p99_us=%.0f p999_us=%.0f max_us=%.0f", n, q(0.5), q(0.99), q(0.999), q(1))
end

local function result(bench, variant, samples)
  io.stdout:write(sformat("RESULT bench=%s variant=%s %s\n", bench, variant, stats(samples)))
  io.stdout:flush()
end

local sys = S.system(T.tmpfile(SYSTEM))
sys:up(60)
sys:run()
sys:wait_state("main.door", "running", 30)

-- From typing `line` to the transition line `pattern` (after the answer `want`). --> seconds
local function timed(line, want, pattern)
  local from = #sys:transitions()
  local t0 = core.now()
  local out = sys:repl(line)
  assert(out == want, sformat("%s: %s", line, tostring(out)))
  if pattern then sys:wait_line(line, pattern, 30, from) end
  return core.now() - t0
end

local adds, removes, restarts = {}, {}, {}
for _ = 1, ROUNDS do
  for _, h in ipairs(HOSTS) do
    adds[#adds + 1] = timed(sformat('add_child("robots", "%s")', h), sformat("main.robots_%s: added on host %s", h, h),
      "^main%.robots_" .. h .. "%.light: running")
    restarts[#restarts + 1] = timed('restart("door")', "main.door: restarted", "^main%.door: restarted")
  end
  for _, h in ipairs(HOSTS) do
    removes[#removes + 1] = timed(sformat('remove_child("robots_%s")', h), sformat("main.robots_%s: removed", h))
  end
end
result("fleet_add_robot", "group_8_hosts", adds)
result("leaf_restart_repl", "same_host", restarts)
result("fleet_remove_robot", "group_8_hosts", removes)
sys:stop()
T.cleanup()
