-- Restart latency (BENCHMARKS.md format): a leaf killed, to its new process running again (respawned
-- by its daemon, Init, its connections made again both ways, Run acknowledged), under a group's supervision
-- policy (one_for_one, restart on crash and lost), with real daemons and nodes on loopback, wall clock.
--
--   RESULT bench=leaf_restart variant=same_host_sigkill|same_host_sigsegv n=.. p50_us=.. p99_us=.. ...
--     the leaf's process killed (its daemon's exit event is how the supervisor hears of it), restarted on the
--     same host; alternated with the baseline sample by sample (A B A B):
--   RESULT bench=node_spawn_ready variant=same_host n=.. ...
--     the baseline: a fresh node of the same type spawned by the same supervisor's runtime, to its control
--     channel open (spawn, registration, lookup, connect: what any (re)start pays before Init)
--   RESULT bench=leaf_restart variant=failover_host_lost n=.. ...
--     the leaf's host lost (its daemon and processes killed, as tests/scenarios/host_lost.lua): the leaf
--     restarts on its standby host (a fresh system per sample: the lost host stays lost). The group fences
--     (`fence 0.4 s margin 0.2 s`, docs/supervision.md "Fencing"): a channel its daemon closed costs the margin
--   RESULT bench=leaf_restart variant=failover_host_silent n=.. ...
--     the leaf's host silent (its daemon and processes held with SIGSTOP: a cut-off host as its supervisor sees
--     it): lost after `fence` without a heartbeat's answer, restarted on the standby host fence + margin after
--     the last renewal sent to it; `fenced_excess` is the same less fence + margin (what fencing adds no wait to)
-- "Running again" is the answer to a `read` sent to the new process as soon as its supervisor says
-- "restarted": it comes after the node has handled Init and Run (one channel, in order).
-- Usage: dca lua tests/bench/restart_bench.lua [N]   (N samples of each same-host variant, default 30; a third
-- of that for the failover)
local core = require "dca.core"
local S = require "dca.scenario"
local T = require "dca.testing"
S.backend = "real"
local sformat = string.format

local N = tonumber(arg and arg[1]) or 30

local SYSTEM = [[
process P(h, hs, hb) {
  host { hs }
  supervision {
    strategy one_for_one; intensity 1000 in 1 s; restart on crash, lost; standby mid on hb; fence 0.4 s margin 0.2 s;
  }
  instantiated_processes {
    src  instof Constant(hs, 0.01, 1);
    mid  instof Gain(h, 1.0, 0);
    sink instof Gain(hs, 1.0, 0);
  }
  internal_connections(src, run) { src, Out -> mid, In; }
  internal_connections(mid, run) { mid, Out -> sink, In; }
  internal_event_actions { src[run], mid[run], sink }
}
process main() {
  host { "sup" }
  instantiated_processes { p instof P("a", "sup", "b"); }
  internal_event_actions { p }
}
]]
local MID = "main.p.mid"

local function stats(samples)
  table.sort(samples)
  local n = #samples
  local function q(p) return samples[math.max(1, math.min(n, math.ceil(p * n)))] * 1e6 end
  return sformat("n=%d p50_us=%.0f p99_us=%.0f p999_us=%.0f max_us=%.0f", n, q(0.5), q(0.99), q(0.999), q(1))
end

local function result(bench, variant, samples)
  if #samples == 0 then io.stderr:write(bench .. " " .. variant .. ": no samples\n") return end
  io.stdout:write(sformat("RESULT bench=%s variant=%s %s\n", bench, variant, stats(samples)))
  io.stdout:flush()
end

local file = T.tmpfile(SYSTEM)

local function up()
  local sys = S.system(file)
  sys:up(30)
  sys:run()
  sys:wait_state(MID, "running", 30)
  return sys
end

-- The number of "<MID>: restarted" transition lines so far.
local function restarts(sys)
  local n = 0
  for _, l in ipairs(sys:transitions()) do if l:find(MID .. ": restarted", 1, true) then n = n + 1 end end
  return n
end

-- From `act()` (which ends the leaf's process) to the new process's answer after its Run. --> seconds
local function restart_sample(sys, act)
  local before = restarts(sys)
  local t0 = core.now()
  act()
  sys:wait("the restart", function() return restarts(sys) > before end, 30)
  local answered
  sys.sup:to_leaf(MID, { type = "read", port = "In" }, 10, function(r) answered = r end)
  sys:wait("the new process's answer", function() return answered ~= nil end, 30)
  return core.now() - t0
end

-- A fresh node of the leaf's type spawned through the supervisor's runtime, to its control channel. --> seconds
local spawned = 0
local function spawn_sample(sys)
  spawned = spawned + 1
  local child = { name = "bench" .. spawned, path = "main.p.bench" .. spawned, kind = "leaf", type = "Gain",
                  host = "a", args = { 1.0, 0 } }
  local handle, err
  local t0 = core.now()
  sys.sup.rt.spawn(child, function(h, e) handle, err = h, e end)
  sys:wait("the spawn", function() return handle ~= nil or err ~= nil end, 30)
  local dt = core.now() - t0
  assert(handle, err)
  local gone = false
  handle.kill("TERM", function() gone = true end)
  sys:wait("its exit", function() return gone end, 30)
  return dt
end

local sys = up()
-- the restarts are the group supervisor's (a child process), found through its transition lines; the baseline's
-- spawns are the root's own runtime
for _, sig in ipairs({ "KILL", "SEGV" }) do
  local rs, ss = {}, {}
  for _ = 1, N do
    local pid = sys:pid(MID)
    rs[#rs + 1] = restart_sample(sys, function() core.kill(pid, sig) end)
    ss[#ss + 1] = spawn_sample(sys)
  end
  result("leaf_restart", "same_host_sig" .. sig:lower(), rs)
  if sig == "KILL" then result("node_spawn_ready", "same_host", ss) end
end
sys:stop()

-- Host "a" silent: its daemon and its children held, none of them closing a channel.
local function silence(s)
  for _, p in ipairs(s:_host_pids("a")) do core.kill(p, "STOP") end
  core.kill(s.daemons.pids.a, "STOP")
end

local FENCE_AND_MARGIN = 0.6
local lost, silent, excess = {}, {}, {}
for _ = 1, math.max(3, N // 3) do
  local s = up()
  lost[#lost + 1] = restart_sample(s, function() s:lose_host("a") end)
  s:stop()
  s = up()
  local dt = restart_sample(s, function() silence(s) end)
  silent[#silent + 1], excess[#excess + 1] = dt, dt - FENCE_AND_MARGIN
  s:lose_host("a")  -- (the held processes end)
  s:stop()
end
result("leaf_restart", "failover_host_lost", lost)
result("leaf_restart", "failover_host_silent", silent)
result("leaf_restart", "fenced_excess", excess)
T.cleanup()
