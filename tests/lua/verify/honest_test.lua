-- `dca check --verify` is never more sure than it is: a partial exploration (--max-states) proves only what
-- it found and exits 3; a group that can get stuck makes a parent that waits for it stuck; an emitted
-- counter-example checks the state its trace ends in, with the timers running on their own.
local T = require "dca.testing"
local suite = T.suite("honest")

local here = T.here()
local function abs(p) return (p:sub(1, 1) == "/") and p or (os.getenv("PWD") .. "/" .. p) end
local systems = abs(here .. "/systems")

suite:case("a_partial_exploration_says_unknown_and_exits_3", function()
  local file = systems .. "/wide.dca"
  T.dca("check " .. file .. " --verify --no-faults", 1, "VIOLATED  main cannot end done", "holds     main can end done")
  -- stopped after 2 states: no run has ended yet, so neither 'can' nor 'cannot' is proven; the violation of
  -- the exclusion in the first state is
  T.dca("check " .. file .. " --verify --no-faults --max-states 2", 1,
        "unknown   main cannot end done (not proven: the exploration is partial)",
        "unknown   main can end done (not proven", "VIOLATED  never (a and b running)",
        "PARTIAL exploration stopped at the state limit (--max-states): 2 states explored, 1 state left unexplored",
        "not fully verified", "2 verdicts unknown")
  -- without a violation: exit code 3, never 0; and a parent of a partial group is partial too
  local out = T.dca("check " .. file .. " --verify --no-faults --max-states 2 --root top", 1)
  T.ok(not out:find("holds ", 1, true), out)
  T.contains(out, "unknown   top cannot end done")
  T.contains(out, "unknown   whether it runs until it is stopped (it waits on a group explored in part)")
  T.contains(out, "PARTIAL a group below was explored only in part")
  local text = T.read(file):gsub("never %(a and b running%); ", "")
  local quiet = T.tmpfile(text)
  T.dca("check " .. quiet .. " --verify --no-faults --max-states 2", 3, "unknown   main cannot end done",
        "0 violated properties", "PARTIAL: 1 group explored in part (--max-states 2), 2 verdicts unknown")
  T.dca("check " .. quiet .. " --verify --no-faults", 1, "VIOLATED  main cannot end done")
  os.remove(quiet)
end)

suite:case("a_group_that_can_get_stuck_makes_its_waiting_parent_stuck", function()
  local file = systems .. "/stuck_inside.dca"
  local out = T.dca("check " .. file .. " --verify --no-faults", 1,
    "main.d2 (process S)", "FINDING can get stuck: waits forever on ns2",
    "FINDING can get stuck: waits forever on d2 (stuck: main.d2 waits forever on ns2)",
    "-> d2 gets stuck: waits forever on ns2", "VIOLATED  main can end done", "main.d2 gets stuck waiting on ns2")
  T.contains(out, "2 findings")
  -- its replay: the inner trace runs, then main waits for ever with g1 done and d2 running
  local cex = T.tmpname(".lua")
  T.dca("check " .. file .. " --verify --no-faults --emit-scenario " .. cex, 1,
        "the counter-example: main can end done is violated: main.d2 gets stuck")
  T.dca("scenario " .. cex, 0, "main.d2.xs1 done", "0 failed")
  os.remove(cex)
end)

-- The scenario of the first counter-example of `file`, its text changed by `edit` (nil: as written).
local function replay(file, edit, rc, ...)
  local cex = T.tmpname(".lua")
  T.dca("check " .. file .. " --verify --emit-scenario " .. cex, nil)
  local text = T.read(cex)
  if edit then
    local changed, n = edit(text)
    T.ok(n and n > 0, "the edit applies")
    T.write(cex, changed)
  end
  local out = T.dca("scenario " .. cex, rc, ...)
  os.remove(cex)
  return out, text
end

suite:case("a_replay_checks_the_state_its_trace_ends_in", function()
  local file = abs(here .. "/golden/stuck.dca")
  local _, text = replay(file, nil, 0, "the violation: main gets stuck waiting on laser", "0 failed")
  T.contains(text, 'S.ok(sys:state("main.level") ~= "running", "level does not run")')
  T.contains(text, 'S.eq(sys:state("main.laser"), "running", "laser runs")')
  -- the trace cut short (level's DONE left out): laser still runs and nothing ends, but level runs too
  replay(file, function(t) return t:gsub('S%.step%("main%.level done".-\nend%)\n', "") end, 1, "level does not run",
         "1 failed")
end)

suite:case("a_replay_keeps_the_timers_on_in_the_order_of_the_trace", function()
  -- the timers' own ends are awaited, not injected: a trace of the golden timers replays in 15 s of its time
  replay(abs(here .. "/golden/timers.dca"), nil, 0, "main.soon done (its own time: 5 s) (t=5.000)",
         "main.late aborted (its own time: 10 s) (t=15.000)", "0 failed")
end)

suite:case("timers_with_constant_durations_are_ordered_across_steps", function()
  -- t3 starts when t2 ends (at 2 s) and would end at 5 s, after the 4 s Deadline d4 started with t2: the
  -- timers' clocks (dca.verify.zone) know it, so main cannot end DONE
  T.dca("check " .. systems .. "/timer_order.dca --verify", 0, "holds     main cannot end done",
        "can end ABORTED: d4 aborted")
  -- with d4 at 6 s, t3 ends first (at 5 s): main can end DONE, and the trace replays with the timers on
  local text = T.read(systems .. "/timer_order.dca"):gsub('Deadline%("h", 4%)', 'Deadline("h", 6)')
  local path = T.tmpfile(text, ".dca")
  T.dca("check " .. path .. " --verify", 1, "VIOLATED  main cannot end done")
  os.remove(path)
  -- with a supervision policy a restart starts a timer again: no clocks, so t3 may end first
  local sup = T.read(systems .. "/timer_order.dca"):gsub("process main%(%) {", "process main() {\n  supervision { }")
  local spath = T.tmpfile(sup, ".dca")
  T.dca("check " .. spath .. " --verify", 1, "VIOLATED  main cannot end done")
  os.remove(spath)
end)

suite:case("a_property_on_an_operand_that_never_starts_says_so", function()
  T.dca("check " .. systems .. "/vacuous.dca --verify", 1, "VIOLATED  b can end done",
        "b never starts in any run of main", "holds     b cannot end done (vacuous: b never starts)",
        "holds     a cannot end aborted\n")
end)

suite:case("promela_writes_only_the_model_to_standard_output", function()
  local out, rc = T.sh("(" .. T.exe .. " check " .. systems .. "/stuck_inside.dca --verify --promela 2>/dev/null)")
  T.eq(rc, 0)
  T.eq(out:match("^[^\n]*"), "/* dca check --verify --promela: the expression model (SEMANTICS.md), one expression per run */")
  T.dca("check " .. systems .. "/stuck_inside.dca --verify --promela", 0, "stuck_inside.dca: ok: 2 groups")
end)

return suite:run(...)
