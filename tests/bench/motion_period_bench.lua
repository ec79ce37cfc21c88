-- The control periods achieved by MotionControl during the door demo, BENCHMARKS.md format, against
-- a plain 1 ms timer measured in the same run, alternated A B A B.
--
-- The figures come from the source: every node records the intervals between consecutive MainCalc calls of
-- its periodic timer, on its own clock and on the wall clock (host/timers.h, the node's `stats`), and
-- `dca run --sim` prints them for the leaves of MotionControl (RedundancyResolution, XR4000Ctrl,
-- Puma560Ctrl) before it stops the tree. Variants:
--   sim_10ms       the demo as written (MotionControl at 10 ms), lock-step as fast as the machine allows: the
--                  wall interval is the real time one 10 ms control period costs (no wall-clock target)
--   sim_1ms        MotionControl at 1 ms, lock-step as fast as possible: likewise, per 1 ms period
--   realtime_1ms   MotionControl at 1 ms with the world paced to the wall clock (`dca run --realtime`; the
--                  nodes stay in lock-step): the wall interval is the real control period, against 1 ms
-- and the baseline, a Boost.Asio steady_timer at 1 ms in a plain process (tests/bench/raw_timer_bench.cpp).
--
--   RESULT bench=motioncontrol_period variant=<v> leaf=<name> n=.. p50_us=.. p99_us=.. p999_us=.. max_us=..
--          (wall-clock intervals) nominal_us=.. sim_p50_us=.. sim_p99_us=.. sim_max_us=.. door_deg=..
--          opened=yes|no rtf=.. wall_s=.. sim_s=.. seed=..
--   RESULT bench=raw_timer_baseline variant=1ms n=.. p50_us=.. p99_us=.. p999_us=.. max_us=.. min_us=..
--
-- MotionControl's period is the configuration key motion.period (door_open.config; 0.01 by default): the
-- 1 ms variants run `dca run door_open.dca --set motion.period=0.001`.
-- Usage: dca lua tests/bench/motion_period_bench.lua [ROUNDS] [VARIANTS...]   (default: 2 rounds, all three)
-- Env: DCA_EXE, DCA_SOURCE_DIR, DCA_BENCH_DIR (where bench_raw_timer is; default <exe>/../../bench),
--      MOTION_BENCH_SEED (default 0), MOTION_BENCH_BASELINE_TICKS (default 5000)
local exe = os.getenv("DCA_EXE") or "dca"
local src = os.getenv("DCA_SOURCE_DIR") or "."
local bench_dir = os.getenv("DCA_BENCH_DIR") or ((exe:match("^(.*)/bin/[^/]+$") or ".") .. "/bench")
local seed = math.tointeger(tonumber(os.getenv("MOTION_BENCH_SEED") or "0")) or 0
local baseline_ticks = math.tointeger(tonumber(os.getenv("MOTION_BENCH_BASELINE_TICKS") or "5000")) or 5000
local sformat = string.format

local function log(fmt, ...) io.stderr:write(sformat(fmt, ...), "\n") end

local run = require("dca.testing").sh  -- output (stdout and stderr), exit code

local function q(s) return "'" .. tostring(s):gsub("'", "'\\''") .. "'" end

local door = src .. "/worlds/door/systems/door_open.dca"

local VARIANTS = {
  sim_10ms = { period = 0.01 },
  sim_1ms = { period = 0.001 },
  realtime_1ms = { period = 0.001, realtime = true },
}
local ORDER = { "sim_10ms", "sim_1ms", "realtime_1ms" }

local function baseline()
  local out, code = run(sformat("%s %d 1", q(bench_dir .. "/bench_raw_timer"), baseline_ticks))
  local line = out:match("(RESULT bench=raw_timer_baseline[^\n]*)")
  if code ~= 0 or not line then log("raw timer baseline failed (exit %s):\n%s", tostring(code), out) return end
  print(line)
  io.stdout:flush()
end

local function door_run(name)
  local v = VARIANTS[name]
  local cmd = sformat("%s run %s --sim door --seed %d --quiet%s --set motion.period=%g", q(exe), q(door), seed,
    v.realtime and " --realtime" or "", v.period)
  log("motion_period_bench: %s", cmd)
  local out, code = run(cmd)
  local deg = tonumber(out:match("door opened to ([%d.%-]+) deg"))
  local sim, wall = out:match("simulated ([%d.]+) s in ([%d.]+) s of wall%-clock time")
  local lines = 0
  for path, nominal, sn, s50, s99, smax, wn, w50, w99, w999, wmax in out:gmatch(
      "MotionControl period ([%w_.]+): nominal ([%d.]+) ms; sim n (%d+) p50 ([%d.]+) ms p99 ([%d.]+) ms max ([%d.]+) ms; "
      .. "wall n (%d+) p50 ([%d.]+) ms p99 ([%d.]+) ms p999 ([%d.]+) ms max ([%d.]+) ms") do
    lines = lines + 1
    local us = function(x) return tonumber(x) * 1000 end
    print(sformat("RESULT bench=motioncontrol_period variant=%s leaf=%s n=%s p50_us=%.1f p99_us=%.1f p999_us=%.1f "
      .. "max_us=%.1f nominal_us=%.0f sim_n=%s sim_p50_us=%.1f sim_p99_us=%.1f sim_max_us=%.1f door_deg=%s opened=%s "
      .. "rtf=%.2f wall_s=%s sim_s=%s seed=%d exit=%s",
      name, path:match("[^.]+$"), wn, us(w50), us(w99), us(w999), us(wmax), us(nominal), sn, us(s50), us(s99),
      us(smax), deg and sformat("%.1f", deg) or "?", (deg and deg >= 70) and "yes" or "no",
      (tonumber(sim) or 0) / math.max(tonumber(wall) or 1, 1e-9), wall or "?", sim or "?", seed, tostring(code)))
  end
  io.stdout:flush()
  if lines == 0 or code ~= 0 then
    log("door run %s: exit %s, %d period lines; its output:\n%s", name, tostring(code), lines, out)
  end
end

local rounds = math.tointeger(tonumber(arg and arg[1] or "2")) or 2
local chosen = {}
for i = 2, #(arg or {}) do
  if not VARIANTS[arg[i]] then error("motion_period_bench: unknown variant " .. arg[i]) end
  chosen[#chosen + 1] = arg[i]
end
if #chosen == 0 then chosen = ORDER end
for r = 1, rounds do
  for _, name in ipairs(chosen) do
    log("motion_period_bench: round %d: raw 1 ms timer, then the door (%s)", r, name)
    baseline()
    door_run(name)
  end
end
