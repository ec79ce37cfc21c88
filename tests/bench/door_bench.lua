-- The door demo as a benchmark (BENCHMARKS.md format): wall time and real-time factor of the whole supervised
-- door opening in simulated time (`dca run door_open.dca --sim door`: three hosts, the supervisor tree, ~22
-- node processes in lock-step with the world), beside the raw world opening the same door by its built-in
-- script (`dca sim`: no nodes, no supervisors, no sockets), alternated A B A B.
--
--   RESULT bench=door_demo variant=seedN n=<lock-step rounds> p50_us=.. p99_us=.. max_us=.. rtf=.. wall_s=..
--          sim_s=.. door_deg=.. advances=..
--   RESULT bench=raw_world_scripted_door variant=seedN n=1 ... rtf=.. wall_s=.. sim_s=..
--
-- The latency fields of door_demo are the wall time of each lock-step round: one control period of simulated
-- time (10 ms, the controllers' period; MotionControl runs at it) with every due node advanced, answered and
-- drained. In simulated time every controller, MotionControl included, runs at exactly its period (the clock
-- waits for it), so the period achieved is the nominal one; its cost in real time is the round. The periods
-- MotionControl achieves on both clocks, at 10 ms and 1 ms, lock-step and paced to the wall clock, against a
-- plain 1 ms timer: tests/bench/motion_period_bench.lua.
-- Usage: dca lua tests/bench/door_bench.lua [SEEDS...]   (default: 0 3)
local exe = os.getenv("DCA_EXE") or "dca"
local src = os.getenv("DCA_SOURCE_DIR") or "."
local sformat = string.format

local run = require("dca.testing").sh  -- output (stdout and stderr), exit code

local function num(s) return tonumber(s) or 0 end

local function raw(seed)
  local out, code = run(sformat("%s sim --seed %d", exe, seed))
  local sim, wall = out:match("simulated ([%d.]+) s in ([%d.]+) s wall")
  if code ~= 0 or not sim then
    io.stderr:write("raw world run failed:\n" .. out .. "\n")
    return
  end
  sim, wall = num(sim), num(wall)
  local us = wall / sim * 1e4  -- wall per 10 ms of simulated time
  print(sformat("RESULT bench=raw_world_scripted_door variant=seed%d n=1 p50_us=%.1f p99_us=%.1f p999_us=%.1f max_us=%.1f rtf=%.2f wall_s=%.3f sim_s=%.3f",
    seed, us, us, us, us, sim / wall, wall, sim))
end

local function demo(seed)
  local out, code = run(sformat("%s run %s/scripts/systems/door_open.dca --sim door --seed %d --quiet", exe, src, seed))
  local deg = out:match("door opened to ([%d.%-]+) deg")
  local sim, wall = out:match("simulated ([%d.]+) s in ([%d.]+) s of wall%-clock time")
  local rounds, adv, p50, p99, max = out:match("lock%-step: (%d+) rounds, (%d+) advances; wall time per round p50 (%d+) us, p99 (%d+) us, max (%d+) us")
  if code ~= 0 or not sim or not rounds then
    io.stderr:write(sformat("door run (seed %d) failed (exit %s):\n%s\n", seed, tostring(code), out))
    return
  end
  sim, wall = num(sim), num(wall)
  print(sformat("RESULT bench=door_demo variant=seed%d n=%d p50_us=%.1f p99_us=%.1f p999_us=%.1f max_us=%.1f rtf=%.2f wall_s=%.3f sim_s=%.3f door_deg=%s advances=%s",
    seed, num(rounds), num(p50), num(p99), num(max), num(max), sim / wall, wall, sim, deg or "?", adv))
end

local seeds = {}
for _, a in ipairs(arg or {}) do seeds[#seeds + 1] = math.tointeger(tonumber(a)) end
if #seeds == 0 then seeds = { 0, 3 } end
for round = 1, 2 do
  for _, seed in ipairs(seeds) do
    io.stderr:write(sformat("door_bench: round %d, seed %d: raw world, then the supervised system\n", round, seed))
    raw(seed)
    demo(seed)
  end
end
