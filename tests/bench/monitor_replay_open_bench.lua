-- Opening a long recording in `dca monitor FILE.mcap` (docs/monitor.md, "Replay"), BENCHMARKS.md format: a
-- synthetic recording of N samples (default 1,000,000: 508 uncompressed chunks, 144 MB) between two lines
-- of the run, opened alternately A B A B in a fresh `dca lua` process each time:
--   whole  the baseline: the file read whole (core.mcap_read, what dca monitor did before the index)
--   index  dca.monitor.replay.load through the file's index (core.mcap_index): summary, the lines' chunks
--   rows   index, then one signal's rows for the page (every chunk of it read, one at a time)
--   RESULT bench=monitor_replay_open variant=<whole|index|rows> n=1 p50_us=.. p99_us=.. p999_us=.. max_us=..
--          (the wall time of the open) rss_kib=<the process's peak RSS> chunks_read=.. chunks=..
-- Usage: dca lua tests/bench/monitor_replay_open_bench.lua [SAMPLES] [ROUNDS]   (defaults: 1000000 2)
local core = require "dca.core"
local exe = os.getenv("DCA_EXE") or "dca"
local sformat = string.format
local sh = require("dca.testing").sh

local n = math.tointeger(tonumber(arg and arg[1] or "")) or 1000000
local rounds = math.tointeger(tonumber(arg and arg[2] or "")) or 2
local tmp = os.getenv("TMPDIR") or "/tmp"
local file = sformat("%s/dca_monitor_replay_open_bench.mcap", tmp)
local script = sformat("%s/dca_monitor_replay_open_bench_child.lua", tmp)

-- the recording: the run's first and last lines around N samples of /world/sig every 10 ms
local w = assert(core.mcap_writer(file))
local events = w:channel("/dca/events", "dca/events", '{"type":"object"}')
local sig = w:channel("/world/sig", "/world/sig", '{"type":"object"}')
w:write(events, '{"line":"main.a: running","path":"main.a","state":"running"}', 0)
for i = 1, n do
  w:write(sig, sformat('{"x":%d,"y":[%d,%d],"pad":"%s"}', i, 2 * i, 3 * i, ("p"):rep(60)), i * 10000000)
end
w:write(events, '{"line":"main: DONE","path":"main","state":"DONE"}', (n + 1) * 10000000)
local st = assert(w:finish())
local fh = assert(io.open(file, "rb"))
local bytes = fh:seek("end")
fh:close()
io.stderr:write(sformat("monitor_replay_open_bench: %d samples, %d chunks, %d bytes\n", n, st.chunks, bytes))

-- the child: opens the file as `how` says, prints "wall_us chunks_read chunks rss_kib"
local f = assert(io.open(script, "w"))
f:write([[
local core = require "dca.core"
local how, file = arg[1], arg[2]
local t0 = core.now()
local read, chunks = 0, 0
if how == "whole" then
  assert(core.mcap_read(file))
  read, chunks = -1, -1
else
  local rec = assert(require("dca.monitor.replay").load(file))
  if how == "rows" then assert(#rec.series[1].rows > 0) end
  read, chunks = rec.index:chunks_read(), #rec.index:summary().chunks
end
local wall = core.now() - t0
local rss = io.open("/proc/self/status"):read("a"):match("VmHWM:%s*(%d+)")
print(string.format("%d %d %d %s", math.floor(wall * 1e6), read, chunks, rss))
]])
f:close()

for round = 1, rounds do
  for _, how in ipairs({ "whole", "index", "rows" }) do
    local out = sh(sformat("%s lua %s %s %s", exe, script, how, file))
    local us, read, chunks, rss = out:match("(%d+) (%-?%d+) (%-?%d+) (%d+)")
    if us then
      if read == "-1" then read, chunks = "all", "all" end
      print(sformat("RESULT bench=monitor_replay_open variant=%s n=1 p50_us=%s p99_us=%s p999_us=%s max_us=%s "
        .. "rss_kib=%s chunks_read=%s chunks=%s bytes=%d round=%d", how, us, us, us, us, rss, read, chunks, bytes,
        round))
    else
      io.stderr:write(sformat("monitor_replay_open_bench: %s failed:\n%s\n", how, out))
    end
  end
end
os.remove(file)
os.remove(script)
