-- The door demo as a benchmark (BENCHMARKS.md format): wall time and real-time factor of the whole supervised
-- door opening in simulated time (`dca run door_open.dca --sim door`: three hosts, the supervisor tree, ~22
-- node processes in lock-step with the world), beside the raw world opening the same door by its built-in
-- script (`dca sim`: no nodes, no supervisors, no sockets), alternated A B A B.
--
--   RESULT bench=door_demo variant=seedN_<placement>_<period> n=<lock-step rounds> p50_us=.. p99_us=.. max_us=..
--          rtf=.. wall_s=.. sim_s=.. door_deg=.. advances=.. processes_per_round=.. per_process_p50_us=..
--          vs_harness=.. run_rtf=.. run_wall_s=.. vs_harness_run=.. world_step_s=..
--   (rtf and wall_s: the whole `dca run`, start-up included; run_*: from time's start to the outcome, as the
--   harness is timed without building its world and controllers; world_step_s: the world's stepping in it)
--   (placement: `dca run --placement process|group|host`, or onehost: host with the three hosts named alike, one
--   shared node for every leaf; period: MotionControl's, 10ms or 1ms; _spinX: `dca run --spin X`, else auto)
--   RESULT bench=raw_world_scripted_door variant=seedN n=1 ... rtf=.. wall_s=.. sim_s=..
--   RESULT bench=door_harness variant=seedN_motionPms n=<10 ms periods> ... rtf=.. wall_s=.. sim_s=.. door_deg=..
--          opened_s=..   (the tick DoorOpen ended DONE; door_demo's opened_s beside it: the same tick, as the
--          harness follows the same time semantics; sim_s goes 0.101 s further, the robot coming to rest)
--   (the baseline: tests/sim/door_harness.h in one process, same seed and period, run just before each
--   supervised run, so the two alternate H A H B ...; door_demo's vs_harness is its rtf over that one's)
--
-- The latency fields of door_demo are the wall time of each lock-step round: one control period of simulated
-- time (10 ms, the controllers' period; MotionControl runs at it) with every due node advanced, answered and
-- drained. In simulated time every controller, MotionControl included, runs at exactly its period (the clock
-- waits for it), so the period achieved is the nominal one; its cost in real time is the round. The periods
-- MotionControl achieves on both clocks, at 10 ms and 1 ms, lock-step and paced to the wall clock, against a
-- plain 1 ms timer: tests/bench/motion_period_bench.lua.
-- Usage: dca lua tests/bench/door_bench.lua [SEEDS...]   (default: 0 3)
--   DCA_BENCH_BEFORE=/path/to/other/build/bin/dca: also that build's run after each harness run
--   (variant suffix _before), so a change is measured before and after in one run
local exe = os.getenv("DCA_EXE") or "dca"
local src = os.getenv("DCA_SOURCE_DIR") or "."
local sformat = string.format

local run = require("dca.testing").sh  -- output (stdout and stderr), exit code

local function num(s) return tonumber(s) or 0 end

-- The baseline: the in-process closed-loop harness (tests/sim/door_harness.h, bench_door_harness) on the same
-- seed and MotionControl period: the same controllers and world in one process, no sockets, no supervisors.
-- --> its rtf, the time DoorOpen ended | nil
local function harness(seed, period)
  local build = os.getenv("DCA_BUILD_DIR") or (src .. "/build/release")
  local out, code = run(sformat("%s/bench/bench_door_harness %d %s", build, seed, period == "1ms" and "0.001" or "0.01"))
  local line = out:match("RESULT[^\n]*")
  if code ~= 0 or not line then io.stderr:write("door harness failed:\n" .. out .. "\n") return end
  local opened = out:match("[%d.]+ %-%s+([%d.]+)%s+DoorOpen")
  print(sformat("%s opened_s=%s", line, opened or "?"))
  return num(line:match("rtf=([%d.]+)")), opened
end

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

-- One supervised run: `placement` (dca run --placement; the variant names it), `period` "10ms" or "1ms"
-- (MotionControl's period: motion.period).
-- The placement "onehost": the system with its three host arguments alike (one shared node for every leaf),
-- a copy beside its configuration in a folder of its own, removed at the end.
local onehost_dir
local function system_file(placement)
  if placement ~= "onehost" then return src .. "/worlds/door/systems/door_open.dca", placement end
  if not onehost_dir then
    onehost_dir = run("mktemp -d"):gsub("%s+$", "")
    local f = assert(io.open(src .. "/worlds/door/systems/door_open.dca")):read("a")
    local one, n = f:gsub('DoorOpenSystem%("vision", "platform", "manipulation"%)', 'DoorOpenSystem("vision", "vision", "vision")')
    assert(n == 1, "door_open.dca: its hosts' line changed")
    assert(io.open(onehost_dir .. "/door_open.dca", "w")):write(one):close()
    run(sformat("cp %s/worlds/door/systems/door_open.config %s/", src, onehost_dir))
  end
  return onehost_dir .. "/door_open.dca", "host"
end

local function demo(seed, placement, period, spin, base, base_opened, before)
  local file, how = system_file(placement)
  local extra = sformat(" --placement %s", how)
  if period == "1ms" then extra = extra .. " --set motion.period=0.001" end
  if spin ~= "auto" then extra = extra .. " --spin " .. spin end
  local out, code = run(sformat("%s run %s --sim door --seed %d --quiet%s", before or exe, file, seed, extra))
  local deg = out:match("door opened to ([%d.%-]+) deg")
  local sim, wall = out:match("simulated ([%d.]+) s in ([%d.]+) s of wall%-clock time")
  -- (a build before these figures were printed has none: 0)
  local run_wall, step = out:match("of wall%-clock time %(([%d.]+) s since time started, ([%d.]+) s of it")
  local rounds, adv, p50, p99, max = out:match("lock%-step: (%d+) rounds, (%d+) advances; wall time per round p50 (%d+) us, p99 (%d+) us, max (%d+) us")
  if code ~= 0 or not sim or not rounds then
    io.stderr:write(sformat("door run (seed %d) failed (exit %s):\n%s\n", seed, tostring(code), out))
    return
  end
  sim, wall, run_wall = num(sim), num(wall), num(run_wall)
  -- processes advanced per round, and the round's p50 shared among them: the lock-step cost per process
  local per_round = num(adv) / math.max(1, num(rounds))
  local run_rtf = run_wall > 0 and sim / run_wall or 0
  local function vs(rtf) return (base or 0) > 0 and rtf / base or 0 end
  local opened = out:match("[%d.]+ %-%s+([%d.]+)%s+main%.dooropensyst%.dooropen%s")
  print(sformat("RESULT bench=door_demo variant=seed%d_%s_%s%s%s n=%d p50_us=%.1f p99_us=%.1f p999_us=%.1f max_us=%.1f rtf=%.2f wall_s=%.3f sim_s=%.3f door_deg=%s advances=%s processes_per_round=%.2f per_process_p50_us=%.1f vs_harness=%.2f run_rtf=%.2f run_wall_s=%.3f vs_harness_run=%.2f world_step_s=%.3f opened_s=%s harness_opened_s=%s",
    seed, placement, period, spin ~= "auto" and "_spin" .. spin or "", before and "_before" or "", num(rounds), num(p50), num(p99), num(max), num(max), sim / wall, wall, sim, deg or "?",
    adv, per_round, num(p50) / math.max(1, per_round), vs(sim / wall), run_rtf, run_wall, vs(run_rtf), num(step),
    opened or "?", base_opened or "?"))
end

local seeds = {}
for _, a in ipairs(arg or {}) do seeds[#seeds + 1] = math.tointeger(tonumber(a)) end
if #seeds == 0 then seeds = { 0, 3 } end
-- DCA_BENCH_PLACEMENTS (default "process,group,host") and DCA_BENCH_PERIODS (default "10ms,1ms") choose the
-- variants; each round runs them all, A B A B.
local function list(env, default)
  local t = {}
  for w in (os.getenv(env) or default):gmatch("[^,%s]+") do t[#t + 1] = w end
  return t
end
local placements, periods = list("DCA_BENCH_PLACEMENTS", "process,group,host"), list("DCA_BENCH_PERIODS", "10ms,1ms")
-- DCA_BENCH_SPIN (default "auto"): `dca run --spin` values, each a variant (suffix _spinX unless auto)
local spins = list("DCA_BENCH_SPIN", "auto")
for round = 1, 2 do
  for _, seed in ipairs(seeds) do
    io.stderr:write(sformat("door_bench: round %d, seed %d: raw world, then the supervised system\n", round, seed))
    raw(seed)
    for _, period in ipairs(periods) do
      for _, placement in ipairs(placements) do
        -- DCA_BENCH_BEFORE=EXE: another build's dca (e.g. before a change) beside this one, after the same
        -- harness run: harness, before, after, A B A B
        for _, spin in ipairs(spins) do
          local before = os.getenv("DCA_BENCH_BEFORE")
          local base, opened = harness(seed, period)
          if before then demo(seed, placement, period, spin, base, opened, before) end
          demo(seed, placement, period, spin, base, opened)
        end
      end
    end
  end
end
if onehost_dir then run("rm -rf " .. onehost_dir) end
