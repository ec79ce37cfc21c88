-- The cost of tapping every port from the start (`dca run --monitor`, --monitor-taps all, the default; the server's
-- hub keeps each topic's history: docs/monitor.md "History") on a 1 kHz loop (BENCHMARKS.md format): five leaves
-- ticking every 1 ms (a Constant into two Gains, two Counters) on the mock UR10, a Timer ending the run after 5 s
-- of simulated time, unpaced (--as-fast-as-possible), no viewer; against the same run with --monitor-taps picked
-- (nothing tapped, the baseline), alternated A B, ROUNDS times.
--   RESULT bench=monitor_taps variant=<all|picked> n=<lock-step rounds> p50_us=.. p99_us=.. p999_us=.. max_us=..
--          (wall time per 1 ms lock-step round) rtf=.. (simulated over wall time since time started)
--          vs_picked=.. (rtf over the baseline's of the same round) taps=.. samples_per_sim_s=..
-- Usage: dca lua tests/bench/monitor_taps_bench.lua [ROUNDS]   (default 3)
local exe = os.getenv("DCA_EXE") or "dca"
local src = os.getenv("DCA_SOURCE_DIR") or "."
local sformat = string.format
local T = require "dca.testing"

local rounds = math.tointeger(tonumber(arg and arg[1])) or 3
local system = os.tmpname() .. ".dca"
do
  local f = assert(io.open(system, "w"))
  f:write([[process main() {
  instantiated_processes { a instof Constant("h1", 0.001, 1); b instof Gain("h1", 2, 0.001); c instof Gain("h1", 3, 0.001);
                           d instof Counter("h1", 0.001); e instof Counter("h1", 0.001); stop instof Timer("h1", 5); }
  internal_connections(b, fb) { a, Out -> b, In; }
  internal_connections(c, fc) { b, Out -> c, In; }
  internal_event_actions { stop # (a, d, e, b[fb], c[fc]) }
}
]])
  f:close()
end

local function one(variant, base)
  local out, code = T.sh(sformat("%s run %s --sim mock:%s/worlds/ur10/ur10.urdf --monitor --as-fast-as-possible "
    .. "--monitor-taps %s 2>&1", exe, system, src, variant))
  local sim, wall = out:match("simulated ([%d.]+) s in [%d.]+ s of wall%-clock time %(([%d.]+) s since time started")
  local n, p50, p99, max = out:match("lock%-step: (%d+) rounds, %d+ advances; wall time per round p50 (%d+) us, p99 (%d+) us, max (%d+) us")
  if code ~= 0 or not sim or not n then
    io.stderr:write(sformat("run %s failed (exit %s):\n%s\n", variant, tostring(code), out:sub(-2000)))
    return
  end
  local taps, taken = out:match("live taps: (%d+) ports, (%d+) samples taken")
  local rtf = tonumber(sim) / tonumber(wall)
  print(sformat("RESULT bench=monitor_taps variant=%s n=%d p50_us=%.1f p99_us=%.1f p999_us=%.1f max_us=%.1f rtf=%.2f "
    .. "vs_picked=%.2f taps=%d samples_per_sim_s=%.0f", variant, tonumber(n), tonumber(p50), tonumber(p99),
    tonumber(max), tonumber(max), rtf, base and rtf / base or 1, tonumber(taps) or 0, (tonumber(taken) or 0) / tonumber(sim)))
  io.stdout:flush()
  return rtf
end

for r = 1, rounds do
  io.stderr:write(sformat("monitor_taps_bench: round %d of %d: picked, all\n", r, rounds))
  local base = one("picked")
  one("all", base)
end
os.remove(system)
