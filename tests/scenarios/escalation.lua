-- Escalation through three levels on three hosts (scripts/systems/test_escalation.dca), in memory and with real
-- processes (three daemons on loopback): main (h1) > mid (h2) > low (h3) > leaf. SIGSEGVs of the leaf are
-- restarted by low twice (2 in 60 s); the third makes low give up (its children stopped, ABORTED, saying so);
-- mid restarts low's whole subtree once (1 in 60 s), then gives up; main restarts mid's once, then gives up:
-- the run ends ABORTED, the root's reason naming the leaf's crash, the first cause. Nothing loops.
local S = require "dca.scenario"
local src = os.getenv("DCA_SOURCE_DIR") or "."
local sys = S.system(src .. "/scripts/systems/test_escalation.dca")
local LEAF = "main.mid.low.leaf"
-- Under a shared placement (`--placement group|host`) a crash reason ends with the shared node's note.
local function begins(got, want) S.eq(tostring(got):sub(1, #want), want) end

-- Waits until `group` has been restarted (after line `from`) and the leaf runs in its new subtree: its `running`
-- line comes after the parent's `restarting` line, and before the group's `restarted` line (said once the group's
-- run is answered, its subtree running).
local function restarted(group, budget, from)
  local line, at = sys:wait_restart(group, 30, from)
  S.contains(line, group .. ": restarted " .. budget)
  local parent, name = group:match("^(.*)%.([^.]+)$")
  local _, began = sys:wait_line(parent .. " restarting " .. name,
    "^" .. parent:gsub("%p", "%%%0") .. ": %S+ after .*: restarting [%w_, ]*" .. name, 1, from)
  local _, ran = sys:wait_line(LEAF .. " running again", "^main%.mid%.low%.leaf: running", 1, began)
  S.ok(ran < at, "the leaf ran before its group said it restarted")
end

S.step("the tree runs on three hosts", function()
  sys:up()
  sys:run()
  sys:wait_state(LEAF, "running", 10)
  S.eq({ sys:host("main"), sys:host("main.mid"), sys:host("main.mid.low"), sys:host(LEAF) }, { "h1", "h2", "h3", "h3" })
end)

S.step("low restarts its leaf twice, then gives up; mid restarts low", function()
  local from = #sys:transitions()
  local kills, gave_up = sys:crash(LEAF, 3, "SEGV", 30)
  S.eq(kills, 3)
  begins(gave_up, "main.mid.low: restart intensity 2 in 60 s exceeded; last: leaf killed by SIGSEGV on host h3")
  S.eq(#sys:lines_matching("^main%.mid%.low%.leaf: restarted %d/2 in 60 s", from), 2)
  restarted("main.mid.low", "1/1 in 60 s", from)
  S.eq(sys.outcome, nil, "the root's algebra saw nothing")
  -- low's running child (leaf had crashed) was stopped before low's outcome reached mid (a shared node ends it
  -- with leaf's crash: nothing left to stop)
  if (S.placement or "process") == "process" then
    local stopped, heard
    for i, l in ipairs(sys:transitions()) do
      if i > from and l:find("^main%.mid%.low%.other: stopped") then stopped = stopped or i end
      if i > from and l:find("^main%.mid: one_for_one after low escalated") then heard = heard or i end
    end
    S.ok(stopped and heard and stopped < heard, "other stopped, then mid heard of the escalation")
  end
end)

S.step("low gives up again: mid is past its budget and gives up; main restarts mid", function()
  local from = #sys:transitions()
  S.eq(select(2, sys:crash(LEAF, 3, "SEGV", 30)) ~= nil, true)
  S.contains(sys:wait_escalation("main.mid", 30, from),
    "main.mid: restart intensity 1 in 60 s exceeded; last: low escalated: restart intensity 2 in 60 s exceeded")
  restarted("main.mid", "1/1 in 60 s", from)
end)

S.step("the third time up: main gives up, the run ends ABORTED naming the leaf's crash", function()
  local from = #sys:transitions()
  sys:crash(LEAF, 3, "SEGV", 30)
  restarted("main.mid.low", "1/1 in 60 s", from)
  sys:crash(LEAF, 3, "SEGV", 30)
  local out = sys:wait_outcome(30)
  S.eq(out.type, "aborted")
  S.eq(out.path, LEAF)
  begins(out.reason, "restart intensity 1 in 60 s exceeded; last: mid escalated: restart intensity 1 in 60 s "
    .. "exceeded; last: low escalated: restart intensity 2 in 60 s exceeded; last: leaf killed by SIGSEGV on host h3")
  sys:wait_escalation("main", 30, from)
end)
return S.finish()
