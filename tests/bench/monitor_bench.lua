-- The web monitor's benchmarks (BENCHMARKS.md format), in tests/monitor/bench.mjs (Node.js, headless chromium
-- through puppeteer-core, installed by scripts/setup): the door run's rtf with no monitor, with the monitor and
-- no page, and with a page watching (alternated, DCA_BENCH_ROUNDS rounds, default 3); and the page's frame
-- intervals on the 1,000-leaf system, running beside idle.
local core = require "dca.core"

local src = os.getenv("DCA_SOURCE_DIR") or "."
local exe = os.getenv("DCA_EXE") or core.exe_path()
local rounds = os.getenv("DCA_BENCH_ROUNDS") or "3"

for _, what in ipairs({ "rtf", "big" }) do
  local pid, err = core.spawn({ "/usr/bin/node", src .. "/tests/monitor/bench.mjs", what, exe, src, rounds })
  if not pid then io.stderr:write("monitor_bench: ", tostring(err), "\n") os.exit(1) end
  local ended
  repeat core.sleep(0.1) ended = core.reap(pid) until ended
  if ended.code ~= 0 then io.stderr:write("monitor_bench: ", what, " failed\n") end
end
