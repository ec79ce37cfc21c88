-- Lock-step at scale (BENCHMARKS.md format; issue #36's goal "1,000 leaves at 10 ms faster than real time on 2
-- cores, in the default placement, the cost per leaf flat from 100 to 1,000"): a system of N Counter leaves
-- (10 ms period, 200 ticks: 2 s of simulated time) in N/10 groups of one ten-way `,`, on one host, run by
-- `dca run FILE --sim mock:tests/sim/robots/sensor_rover.urdf` (mock hardware: the world costs nothing, so the
-- rounds are the lock-step machinery and the leaves' timers alone) in the default placement (`host`: every leaf
-- in one shared node). Beside it in the same run, alternated size by size (A B C A B C): the smallest size is the
-- baseline of the per-leaf cost, and the same smallest system with one process per leaf (`--placement process`,
-- the old default) the one a shared node is judged against.
--
--   RESULT bench=lockstep_scale variant=<N>leaves_<placement> n=<rounds> p50_us=.. p99_us=.. p999_us=.. max_us=..
--          per_leaf_p50_us=.. vs_smallest=.. sim_s=.. run_wall_s=.. rtf=.. budget_share=..
--   (the latency fields: the wall time of each 10 ms lock-step round, from the run's summary, which gives p50,
--   p99 and max only, so p999_us repeats p99; per_leaf_p50_us: p50 / N; vs_smallest: that over the smallest
--   size's in the same round; run_wall_s: from time's start to the outcome; rtf: simulated s per wall s of it;
--   budget_share: p50 over the 10 ms period, under 1 is faster than real time)
-- Usage: dca lua tests/bench/lockstep_scale_bench.lua [SIZES...]   (default: 100 300 1000)
--   DCA_BENCH_ROUNDS (default 2)
local T = require("dca.testing")
local exe = os.getenv("DCA_EXE") or "dca"
local src = os.getenv("DCA_SOURCE_DIR") or "."
local sformat = string.format
local PERIOD_S, TICKS = 0.01, 200

-- The system of n leaves (n a multiple of 10).
local function system(n)
  local lines = { "process G(h) {", "  host { h }", "  instantiated_processes {" }
  local names = {}
  for i = 1, 10 do
    lines[#lines + 1] = sformat("    c%d instof Counter(h, %g, %d);", i, PERIOD_S, TICKS)
    names[#names + 1] = "c" .. i
  end
  lines[#lines + 1] = "  }"
  lines[#lines + 1] = "  internal_event_actions { " .. table.concat(names, ", ") .. " }"
  lines[#lines + 1] = "}"
  lines[#lines + 1] = "process main() {"
  lines[#lines + 1] = '  host { "h1" }'
  lines[#lines + 1] = "  instantiated_processes {"
  local groups = {}
  for g = 1, n // 10 do
    lines[#lines + 1] = sformat('    g%d instof G("h1");', g)
    groups[#groups + 1] = "g" .. g
  end
  lines[#lines + 1] = "  }"
  lines[#lines + 1] = "  internal_event_actions { " .. table.concat(groups, ", ") .. " }"
  lines[#lines + 1] = "}"
  return table.concat(lines, "\n") .. "\n"
end

-- One run --> { rounds, p50, p99, max, sim, run_wall } | nil
local function run(file, placement)
  local out, code = T.sh(sformat("timeout 600 %s run %s --sim mock:%s/tests/sim/robots/sensor_rover.urdf --quiet%s",
    exe, file, src, placement == "host" and "" or " --placement " .. placement))
  local sim, run_wall = out:match("simulated ([%d.]+) s in [%d.]+ s of wall%-clock time %(([%d.]+) s since time started")
  local rounds, p50, p99, max = out:match("lock%-step: (%d+) rounds, %d+ advances; wall time per round p50 (%d+) us, "
    .. "p99 (%d+) us, max (%d+) us")
  if code ~= 0 or not sim or not rounds then
    io.stderr:write(sformat("lockstep_scale_bench: %s (%s) failed (exit %s):\n%s\n", file, placement, tostring(code),
      out:sub(-3000)))
    return nil
  end
  return { rounds = tonumber(rounds), p50 = tonumber(p50), p99 = tonumber(p99), max = tonumber(max),
           sim = tonumber(sim), run_wall = tonumber(run_wall) }
end

local sizes = {}
for _, a in ipairs(arg or {}) do sizes[#sizes + 1] = math.tointeger(tonumber(a)) end
if #sizes == 0 then sizes = { 100, 300, 1000 } end
table.sort(sizes)
local files = {}
for _, n in ipairs(sizes) do
  assert(n and n >= 10 and n % 10 == 0, "sizes are multiples of 10")
  files[n] = T.tmpfile(system(n))
end

local function report(n, placement, r, smallest)
  local per_leaf = r.p50 / n
  print(sformat("RESULT bench=lockstep_scale variant=%dleaves_%s n=%d p50_us=%d p99_us=%d p999_us=%d max_us=%d "
    .. "per_leaf_p50_us=%.3f vs_smallest=%.2f sim_s=%.3f run_wall_s=%.3f rtf=%.2f budget_share=%.4f", n, placement,
    r.rounds, r.p50, r.p99, r.p99, r.max, per_leaf, smallest and per_leaf / smallest or 1, r.sim, r.run_wall,
    r.sim / math.max(r.run_wall, 1e-9), r.p50 / (PERIOD_S * 1e6)))
  io.stdout:flush()
  return per_leaf
end

local rounds = tonumber(os.getenv("DCA_BENCH_ROUNDS") or "2")
for round = 1, rounds do
  local smallest
  for _, n in ipairs(sizes) do
    io.stderr:write(sformat("lockstep_scale_bench: round %d, %d leaves, default placement (host)\n", round, n))
    local r = run(files[n], "host")
    if r then
      local per_leaf = report(n, "host", r, smallest)
      smallest = smallest or per_leaf
    end
  end
  io.stderr:write(sformat("lockstep_scale_bench: round %d, %d leaves, one process each\n", round, sizes[1]))
  local r = run(files[sizes[1]], "process")
  if r then report(sizes[1], "process", r, smallest) end
end
T.cleanup()
