-- The cost of recording the supervised door run (BENCHMARKS.md format): `dca run door_open.dca --sim
-- door` without recording (the baseline), recording the world's signals to MCAP (`--record FILE.mcap`), and
-- recording every port of the tree too (`--record-ports all`: 22 taps into the world, ARCHITECTURE.md "Taps"),
-- that with its chunks in lz4 and uncompressed instead of zstd (`--record-compression`), alternated, twice per
-- seed. tests/bench/recording_bench.cpp measures the recorder alone (the
-- scripted door in one process).
--
--   RESULT bench=door_recording variant=seedN_<none|world_signals|all_ports[_lz4|_uncompressed]> n=<rounds>
--          p50_us=.. p99_us=.. p999_us=.. max_us=.. (wall time per lock-step round, one 10 ms control period)
--          rtf=.. wall_s=.. sim_s=.. vs_none=<rtf over the baseline's just before> mb=<file size>
--          mb_per_sim_min=.. messages=.. channels=.. msgs_per_sim_s=..
-- Usage: dca lua tests/bench/recording_run_bench.lua [SEEDS...]   (default: 3)
local exe = os.getenv("DCA_EXE") or "dca"
local src = os.getenv("DCA_SOURCE_DIR") or "."
local sformat = string.format
local run = require("dca.testing").sh

local function num(s) return tonumber(s) or 0 end

local function size_of(path)
  local f = io.open(path, "rb")
  if not f then return 0 end
  local n = f:seek("end")
  f:close()
  return n or 0
end

local VARIANTS = {
  { name = "none", args = "" },
  { name = "world_signals", args = " --record %s" },
  { name = "all_ports", args = " --record %s --record-ports all" },  -- zstd chunks, the default
  { name = "all_ports_lz4", args = " --record %s --record-ports all --record-compression lz4" },
  { name = "all_ports_uncompressed", args = " --record %s --record-ports all --record-compression none" },
}

-- One run of `v`; prints its RESULT line. `base`: the baseline's rtf in this round. --> its rtf
local function one(seed, v, base)
  local file = sformat("%s/dca_recording_run_bench_%s.mcap", os.getenv("TMPDIR") or "/tmp", v.name)
  os.remove(file)
  local out, code = run(sformat("%s run %s/worlds/door/systems/door_open.dca --sim door --seed %d --quiet" .. v.args, exe,
    src, seed, file))
  local sim, wall = out:match("simulated ([%d.]+) s in ([%d.]+) s of wall%-clock time")
  local rounds, p50, p99, max = out:match("lock%-step: (%d+) rounds, %d+ advances; wall time per round p50 (%d+) us, p99 (%d+) us, max (%d+) us")
  if code ~= 0 or not sim or not rounds then
    io.stderr:write(sformat("door run %s (seed %d) failed (exit %s):\n%s\n", v.name, seed, tostring(code), out))
    return
  end
  sim, wall = num(sim), num(wall)
  local messages, channels = out:match("recorded [^\n]-: (%d+) messages on (%d+) channels")
  local bytes = v.args ~= "" and size_of(file) or 0
  os.remove(file)
  local rtf = sim / wall
  print(sformat("RESULT bench=door_recording variant=seed%d_%s n=%d p50_us=%.1f p99_us=%.1f p999_us=%.1f max_us=%.1f "
    .. "rtf=%.2f wall_s=%.3f sim_s=%.3f vs_none=%.2f mb=%.2f mb_per_sim_min=%.2f messages=%d channels=%d msgs_per_sim_s=%.0f",
    seed, v.name, num(rounds), num(p50), num(p99), num(max), num(max), rtf, wall, sim, base and rtf / base or 1,
    bytes / 1e6, bytes / 1e6 / sim * 60, num(messages), num(channels), num(messages) / sim))
  return rtf
end

local seeds = {}
for _, a in ipairs(arg or {}) do seeds[#seeds + 1] = math.tointeger(tonumber(a)) end
if #seeds == 0 then seeds = { 3 } end
for round = 1, 2 do
  for _, seed in ipairs(seeds) do
    io.stderr:write(sformat("recording_run_bench: round %d, seed %d: none, world signals, all ports (zstd, lz4, none)\n",
      round, seed))
    local base
    for _, v in ipairs(VARIANTS) do
      local rtf = one(seed, v, base)
      if v.name == "none" then base = rtf end
    end
  end
end
