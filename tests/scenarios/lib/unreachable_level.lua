-- scripts/systems/test_three_hosts.dca with its detector's level out of reach (Threshold 1e9 instead of 30, which
-- is reached 0.3 s after the run: in real time nothing would order a loss before it), so that only a loss can end
-- the run (host_lost.lua, heartbeat_lost.lua); written to a temporary file of dca.testing, which T.cleanup()
-- removes. --> its path
return function()
  local T = require "dca.testing"
  local text, n = T.read(T.src .. "/scripts/systems/test_three_hosts.dca"):gsub("Threshold%(h, 30%)", "Threshold(h, 1e9)")
  assert(n == 1, "test_three_hosts.dca: no Threshold(h, 30) to raise")
  return T.tmpfile(text)
end
