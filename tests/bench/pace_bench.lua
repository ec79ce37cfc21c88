-- The pace of a watched run (docs/time.md "Pace"), BENCHMARKS.md format: `dca run door_open.dca --sim door
-- --monitor` is paced to the wall clock (1x) by default, so its wall time from time's start to the outcome
-- should be its simulated time (wall_per_sim 1.00, a little over when a round costs more than its period).
-- Beside it, the same run with --as-fast-as-possible (the baseline: what the system costs unpaced, as it ran
-- before pacing was the default), alternated A B A B.
--
--   RESULT bench=door_watched variant=seedN_<1x|max> n=<lock-step rounds> p50_us=.. p99_us=.. p999_us=..
--          max_us=.. sim_s=.. run_wall_s=.. wall_per_sim=..
--   (the latency fields: the wall time of each lock-step round, as door_bench.lua's; the run's summary gives
--   p50, p99 and max only, so p999_us repeats p99)
-- Usage: dca lua tests/bench/pace_bench.lua [SEEDS...]   (default: 0)
local exe = os.getenv("DCA_EXE") or "dca"
local src = os.getenv("DCA_SOURCE_DIR") or "."
local sformat = string.format
local run = require("dca.testing").sh  -- output (stdout and stderr), exit code

local function num(s) return tonumber(s) or 0 end

-- One watched run, paced (`variant` 1x) or not (max). A page never connects: no --monitor-wait.
local function watched(seed, variant)
  local out, code = run(sformat("timeout 300 %s run %s/worlds/door/systems/door_open.dca --sim door --seed %d "
    .. "--quiet --monitor%s", exe, src, seed, variant == "max" and " --as-fast-as-possible" or ""))
  local sim, run_wall = out:match("simulated ([%d.]+) s in [%d.]+ s of wall%-clock time %(([%d.]+) s since time started")
  local rounds, p50, p99, max = out:match("lock%-step: (%d+) rounds, %d+ advances; wall time per round p50 (%d+) us, "
    .. "p99 (%d+) us, max (%d+) us")
  if code ~= 0 or not sim or not rounds then
    io.stderr:write(sformat("watched door run (seed %d, %s) failed (exit %s):\n%s\n", seed, variant, tostring(code), out))
    return
  end
  sim, run_wall = num(sim), num(run_wall)
  print(sformat("RESULT bench=door_watched variant=seed%d_%s n=%s p50_us=%s p99_us=%s p999_us=%s max_us=%s "
    .. "sim_s=%.3f run_wall_s=%.3f wall_per_sim=%.3f", seed, variant, rounds, p50, p99, p99, max, sim, run_wall,
    run_wall / math.max(sim, 1e-9)))
end

local seeds = {}
for _, a in ipairs(arg or {}) do seeds[#seeds + 1] = tonumber(a) end
if #seeds == 0 then seeds = { 0 } end
for _, seed in ipairs(seeds) do
  for round = 1, 2 do
    io.stderr:write(sformat("pace_bench: seed %d, round %d: paced (1x), then unpaced (max)\n", seed, round))
    watched(seed, "1x")
    watched(seed, "max")
  end
end
