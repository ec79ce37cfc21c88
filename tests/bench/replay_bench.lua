-- Replay and black box against the live door run (BENCHMARKS.md format), alternated A B C D in each round, two
-- rounds: the live run alone (the baseline, `--sim door`), the live run recording every port
-- (`--record-ports all`, the file the replay reads), the live run with a black box of that recording
-- (`--blackbox 5,1`), and the replay of the round's recording (`--replay REC.mcap`: no physics, every
-- controller live; docs/recording.md, "Replay" and "Black box").
--
--   RESULT bench=door_replay variant=<live|live_record_all|live_blackbox|replay> n=<lock-step rounds>
--          p50_us=.. p99_us=.. p999_us=.. max_us=.. (wall time per lock-step round)
--          rtf=.. wall_s=.. sim_s=.. vs_live=<rtf over the live baseline's of this round>
-- Usage: dca lua tests/bench/replay_bench.lua [ROUNDS]   (default: 2)
local exe = os.getenv("DCA_EXE") or "dca"
local src = os.getenv("DCA_SOURCE_DIR") or "."
local sformat = string.format
local sh = require("dca.testing").sh

local tmp = os.getenv("TMPDIR") or "/tmp"
local rec = sformat("%s/dca_replay_bench_rec.mcap", tmp)
local box = sformat("%s/dca_replay_bench_box.mcap", tmp)

local VARIANTS = {
  { name = "live", args = "--sim door" },
  { name = "live_record_all", args = "--sim door --record " .. rec .. " --record-ports all" },
  { name = "live_blackbox", args = "--sim door --record " .. box .. " --record-ports all --blackbox 5,1" },
  { name = "replay", args = "--replay " .. rec },
}

-- The door run with `args`: the figures of its summary, or nil after saying why.
local function figures(v)
  local out, code = sh(sformat("%s run %s/worlds/door/systems/door_open.dca --quiet %s", exe, src, v.args))
  local f = {}
  f.sim, f.wall = out:match("simulated ([%d.]+) s in ([%d.]+) s of wall%-clock time")
  f.rounds, f.p50, f.p99, f.max =
    out:match("lock%-step: (%d+) rounds, %d+ advances; wall time per round p50 (%d+) us, p99 (%d+) us, max (%d+) us")
  if code ~= 0 or not f.sim or not f.rounds then
    io.stderr:write(sformat("replay_bench: %s failed (exit %s):\n%s\n", v.name, tostring(code), out))
    return nil
  end
  for k, x in pairs(f) do f[k] = tonumber(x) end
  return f
end

local rounds = math.tointeger(tonumber(arg and arg[1] or "")) or 2
for round = 1, rounds do
  io.stderr:write(sformat("replay_bench: round %d: live, live recording all ports, live black box, replay\n", round))
  local base
  for _, v in ipairs(VARIANTS) do
    local f = figures(v)
    if f then
      local rtf = f.sim / f.wall
      base = base or rtf
      print(sformat("RESULT bench=door_replay variant=%s n=%d p50_us=%d p99_us=%d p999_us=%d max_us=%d rtf=%.2f "
        .. "wall_s=%.3f sim_s=%.3f vs_live=%.2f", v.name, f.rounds, f.p50, f.p99, f.max, f.max, rtf, f.wall, f.sim,
        rtf / base))
    end
  end
  os.remove(box:gsub("%.mcap$", "-1.mcap"))
end
os.remove(rec)
