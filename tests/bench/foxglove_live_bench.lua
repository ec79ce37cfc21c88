-- The cost of watching the door run live with Foxglove (BENCHMARKS.md format): `dca run door_open.dca
-- --sim door` without a monitor (the baseline), with `--monitor` and a Foxglove client subscribed to nothing
-- (with --monitor-taps picked: no tap at all; and by default, --monitor-taps all: every port and world signal
-- tapped from the start into the server's history), to every port of the tree (22 live taps, "/main/..."), and to
-- every channel (the world's signals too), alternated A B C D E, twice. The client is tests/foxglove/bench_client.mjs (@foxglove/ws-protocol, installed by
-- scripts/setup); with a monitor, time starts once the taps are made (--monitor-wait), so run_rtf (simulated
-- time over the wall time since time started) compares like with like.
--
--   RESULT bench=door_foxglove variant=seedN_<plain|monitor_untapped|monitor_idle|ports|all> n=<lock-step rounds>
--          p50_us=.. p99_us=.. p999_us=.. max_us=.. (wall time per lock-step round)
--          run_rtf=.. run_wall_s=.. sim_s=.. vs_plain=<run_rtf over the baseline's> channels=.. subscribed=..
--          messages=.. msgs_per_sim_s=.. kb_per_sim_s=.. tap_taken=.. tap_dropped=.. (the live taps' inputs: a
--          busy root drops the oldest; samples the client lost besides are host/web's droppable queue's)
-- Usage: dca lua tests/bench/foxglove_live_bench.lua [SEED]   (default 3)
local exe = os.getenv("DCA_EXE") or "dca"
local src = os.getenv("DCA_SOURCE_DIR") or "."
local sformat = string.format
local run = require("dca.testing").sh

local function num(s) return tonumber(s) or 0 end

local seed = math.tointeger(tonumber(arg and arg[1])) or 3
local system = src .. "/worlds/door/systems/door_open.dca"
local client = src .. "/tests/foxglove/bench_client.mjs"

local VARIANTS = {
  { name = "plain" },
  { name = "monitor_untapped", prefix = "", args = " --monitor-taps picked" },
  { name = "monitor_idle", prefix = "" },
  { name = "ports", prefix = "/main/" },
  { name = "all", prefix = "/" },
}

local function one(v, base)
  local cmd = v.prefix and sformat("node %s %s %s '%s' --seed %d%s", client, exe, system, v.prefix, seed, v.args or "")
    or sformat("%s run %s --sim door --seed %d", exe, system, seed)
  local out, code = run(cmd)
  local sim, run_wall = out:match("simulated ([%d.]+) s in [%d.]+ s of wall%-clock time %(([%d.]+) s since time started")
  local rounds, p50, p99, max = out:match("lock%-step: (%d+) rounds, %d+ advances; wall time per round p50 (%d+) us, p99 (%d+) us, max (%d+) us")
  if code ~= 0 or not sim or not rounds then
    io.stderr:write(sformat("door run %s failed (exit %s):\n%s\n", v.name, tostring(code), out:sub(-3000)))
    return
  end
  sim, run_wall = num(sim), num(run_wall)
  local channels, subscribed, messages, bytes = out:match("foxglove_client: channels=(%d+) subscribed=(%d+) messages=(%d+) bytes=(%d+)")
  local taken, tap_dropped = out:match("live taps: %d+ ports, (%d+) samples taken, (%d+) dropped")
  local rtf = sim / run_wall
  print(sformat("RESULT bench=door_foxglove variant=seed%d_%s n=%d p50_us=%.1f p99_us=%.1f p999_us=%.1f max_us=%.1f "
    .. "run_rtf=%.2f run_wall_s=%.3f sim_s=%.3f vs_plain=%.2f channels=%d subscribed=%d messages=%d msgs_per_sim_s=%.0f "
    .. "kb_per_sim_s=%.1f tap_taken=%d tap_dropped=%d", seed, v.name, num(rounds), num(p50), num(p99), num(max), num(max), rtf, run_wall, sim,
    base and rtf / base or 1, num(channels), num(subscribed), num(messages), num(messages) / sim, num(bytes) / 1e3 / sim,
    num(taken), num(tap_dropped)))
  return rtf
end

for round = 1, 2 do
  io.stderr:write(sformat("foxglove_live_bench: round %d: plain, monitor untapped, monitor idle, ports, all channels\n", round))
  local base
  for _, v in ipairs(VARIANTS) do
    local rtf = one(v, base)
    if v.name == "plain" then base = rtf end
  end
end
