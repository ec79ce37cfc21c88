-- A crash loop ends by escalation (scripts/systems/test_crash_loop.dca), in memory and with real processes:
-- crashy dies by SIGSEGV at its 5th tick every time it runs; its group restarts it 3 times within 60 s, then
-- gives up: its other child stopped, the group ABORTED saying so, and the run ends ABORTED with that reason,
-- rather than looping for ever.
local S = require "dca.scenario"
local src = os.getenv("DCA_SOURCE_DIR") or "."
local sys = S.system(src .. "/scripts/systems/test_crash_loop.dca")

S.step("the loop runs; crashy crashes and is restarted 3 times, then its group gives up", function()
  sys:up()
  local from = #sys:transitions()
  sys:run()
  local out = sys:wait_outcome(60)
  S.eq(#sys:lines_matching("^main%.loop%.crashy: exited: killed by SIGSEGV", from), 4)
  S.eq(#sys:lines_matching("^main%.loop%.crashy: restarted %d/3 in 60 s", from), 3)
  S.eq(out.type, "aborted")
  S.eq(out.path, "main.loop.crashy")
  local want = "restart intensity 3 in 60 s exceeded; last: crashy killed by SIGSEGV on host h1"
  S.eq(out.reason:sub(1, #want), want, "(under a shared placement the shared node's note follows)")
  -- the other children stopped, in reverse start order (LIFO); in a shared node they end with crashy at each
  -- crash and restart with it, so at the escalation they have ended already and there is nothing to stop
  local aborting = {}
  for _, l in ipairs(sys:lines_matching("^main%.loop%.%a+: aborting", from)) do
    aborting[#aborting + 1] = l:match("^main%.loop%.(%a+):")
  end
  local shared = (S.placement or "process") ~= "process"
  S.eq(aborting, shared and {} or { "calm", "steady" }, "stopped LIFO (crashy had crashed)")
  for _, n in ipairs({ "steady", "calm" }) do
    S.ok(#sys:lines_matching("^main%.loop%." .. n .. ": stopped", from) + #sys:lines_matching("^main%.loop%." .. n
      .. ": exited", from) >= 1, n .. " stopped")
  end
  -- and before the group's outcome reached its parent (main then aborted)
  local last_stop, aborted = 0, nil
  for i, l in ipairs(sys:transitions()) do
    if i > from and l:find("^main%.loop%.%a+: stopped") then last_stop = i end
    if i > from and l:find("^main: aborted") then aborted = aborted or i end
  end
  S.ok(aborted and last_stop < aborted, "the children stopped before main heard of the escalation")
end)
return S.finish()
