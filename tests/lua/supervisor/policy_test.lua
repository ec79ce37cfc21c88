-- Supervision policies (dca.supervisor.policy and the engine's strategies, intensity and escalation) on the
-- in-memory cluster: which children restart, in which order they stop and start, the budget's window, the
-- escalation up the tree with the first cause, and that nothing changes without a policy.
local T = require "dca.testing"
local fake = require "dca.supervisor.memory"
local policy = require "dca.supervisor.policy"
local suite = T.suite("policy")

local leaf, group, root = fake.leaf, fake.group, fake.root

-- A group `w` on h1 of three leaves a, b, c (running until stopped; c ends DONE when injected), with `pol`.
local function workers(pol, expr)
  local g = group("w", "Workers", "h1", expr or "c # (a, b)", {
    leaf("a", "Run", "h1"), leaf("b", "Run", "h2"), leaf("c", "Run", "h1"),
  })
  g.spec.supervision = pol
  return root("main", "h1", "w", { g })
end

local function pol(strategy, n, within, on)
  local kinds = {}
  for _, k in ipairs(on or { "crash", "lost" }) do kinds[k] = true end
  return { strategy = strategy or "one_for_one", intensity = n or 3, within = within or 10, on = kinds }
end

local function running(spec)
  local c = fake.cluster({ behave = {} })
  c:root(spec)
  assert(c:configure())
  c:start()
  c:settle(c.t + 1)
  return c
end

-- Lets `s` seconds of the cluster's time pass (an idle cluster's time stands still otherwise).
local function pass(c, s)
  c:after(s, function() end)
  c:settle(c.t + s)
end

local function pid(c, path)
  for _, p in ipairs(c.procs) do if p.path == path and p.alive then return p.pid end end
end

local function pids(c, paths)
  local t = {}
  for _, p in ipairs(paths) do t[p] = pid(c, p) end
  return t
end

-- The lines matching `pattern`, each reduced to its first capture.
local function lines(c, pattern)
  local out = {}
  for _, l in ipairs(c.lines) do
    local m = l:match(pattern)
    if m then out[#out + 1] = m end
  end
  return out
end

local ABC = { "main.w.a", "main.w.b", "main.w.c" }

-- The workers with `strategy` (3 in 10 s), `who` killed by SIGSEGV. --> the cluster, the pids before and after
local function crash(strategy, who)
  local c = running(workers(pol(strategy)))
  local before = pids(c, ABC)
  c:kill("main.w." .. who, "SEGV")
  c:settle(c.t + 1)
  T.eq(c.outcome, nil, "the algebra saw nothing")
  return c, before, pids(c, ABC)
end

suite:case("pure_parts_plan_window_kind_texts", function()
  local order = { "a", "b", "c", "d" }
  T.eq(policy.plan("one_for_one", order, { c = true }), { "c" })
  T.eq(policy.plan("one_for_all", order, { c = true }), order)
  T.eq(policy.plan("rest_for_one", order, { b = true }), { "b", "c", "d" })
  T.eq(policy.plan("rest_for_one", order, { d = true, b = true }), { "b", "c", "d" })
  T.eq(policy.window({ 1, 2, 5, 9 }, 11, 8), { 5, 9 })
  T.eq(policy.kind("exit"), "crash")
  T.eq(policy.kind("exit", false), "crash")
  T.eq(policy.kind("exit", true), "lost")
  T.eq(policy.kind("aborted", true), "aborted")
  T.eq(policy.kind("escalated", "whatever"), "crash")
  T.eq(policy.exceeded(pol(nil, 3, 10), "vs killed by SIGSEGV on host vision"),
       "restart intensity 3 in 10 s exceeded; last: vs killed by SIGSEGV on host vision")
end)

suite:case("without_a_policy_a_crash_aborts_as_today", function()
  local c = running(workers(nil))
  c:kill("main.w.b", "SEGV")
  c:settle(c.t + 1)
  T.eq(c.outcome and c.outcome.type, "aborted")
  T.eq(c.outcome.path, "main.w.b")
  T.contains(c.outcome.reason, "killed by SIGSEGV")
end)

suite:case("one_for_one_restarts_only_the_crashed_child_and_the_task_carries_on", function()
  local c, before, now = crash("one_for_one", "b")
  T.ok(now["main.w.b"] and now["main.w.b"] ~= before["main.w.b"], "b is a new process")
  T.eq({ now["main.w.a"], now["main.w.c"] }, { before["main.w.a"], before["main.w.c"] })
  T.eq(c:node("main.w.b").running, true, "b runs again")
  T.eq(lines(c, "^(main%.w%.b: restarted 1/3 in 10 s)"), { "main.w.b: restarted 1/3 in 10 s" })
  c:node("main.w.c"):done(7)
  c:settle(c.t + 1)
  T.eq({ c.outcome.type, c.outcome.value }, { "done", 7 })
end)

suite:case("one_for_all_stops_in_reverse_and_starts_in_order", function()
  local c, before, now = crash("one_for_all", "a")
  for _, p in ipairs(ABC) do T.ok(now[p] ~= before[p], p .. " is a new process") end
  T.eq(lines(c, "^(main%.w%.%a): stopping to restart"), { "main.w.c", "main.w.b" }, "LIFO (a had crashed)")
  T.eq(lines(c, "^(main%.w%.%a): restarted"), { "main.w.a", "main.w.b", "main.w.c" })
  for _, p in ipairs(ABC) do T.eq(c:node(p).running, true, p .. " runs again") end
end)

suite:case("rest_for_one_restarts_the_crashed_child_and_those_after_it", function()
  local c, before, now = crash("rest_for_one", "b")
  T.eq(now["main.w.a"], before["main.w.a"], "a is before b: untouched")
  T.ok(now["main.w.b"] ~= before["main.w.b"] and now["main.w.c"] ~= before["main.w.c"])
  T.eq(lines(c, "^(main%.w%.%a): stopping to restart"), { "main.w.c" })
  T.eq(lines(c, "^(main%.w%.%a): restarted"), { "main.w.b", "main.w.c" })
end)

suite:case("past_the_intensity_the_group_escalates_and_names_the_crash", function()
  local c = running(workers(pol("one_for_one", 2, 10)))
  for _ = 1, 2 do
    c:kill("main.w.b", "SEGV")
    c:settle(c.t + 1)
    T.eq(c.outcome, nil)
  end
  T.eq(#lines(c, "^(main%.w%.b: restarted %d/2 in 10 s)"), 2)
  c:kill("main.w.b", "SEGV")
  c:settle(c.t + 1)
  T.eq(c.outcome and c.outcome.type, "aborted")
  T.eq(c.outcome.path, "main.w.b")
  T.eq(c.outcome.reason, "restart intensity 2 in 10 s exceeded; last: b killed by SIGSEGV on host h2")
  T.eq(c:node("main.w.a").running, false, "the other children were stopped")
end)

suite:case("the_window_slides_restarts_older_than_it_do_not_count", function()
  local c = running(workers(pol("one_for_one", 1, 5)))
  for _ = 1, 3 do
    c:kill("main.w.b", "SEGV")
    pass(c, 6)
    T.eq(c.outcome, nil, "one restart per 5 s is within the budget")
  end
  c:kill("main.w.b", "SEGV")
  c:settle(c.t + 1)
  c:kill("main.w.b", "SEGV")
  c:settle(c.t + 1)
  T.eq(c.outcome and c.outcome.type, "aborted", "two within 5 s is not")
end)

suite:case("faults_the_policy_does_not_name_go_to_the_algebra", function()
  local c = running(workers(pol("one_for_one", 3, 10, { "lost" })))
  c:kill("main.w.b", "SEGV")
  c:settle(c.t + 1)
  T.eq(c.outcome and c.outcome.path, "main.w.b")
  local c2 = running(workers(pol("one_for_one", 3, 10, { "aborted" })))
  local before = pid(c2, "main.w.b")
  c2:node("main.w.b"):aborted("sensor fault")
  c2:settle(c2.t + 1)
  T.eq(c2.outcome, nil, "an ABORTED leaf restarted")
  T.ok(pid(c2, "main.w.b") ~= before)
  T.eq(c2:node("main.w.b").running, true)
end)

suite:case("a_crash_whose_reason_says_lost_is_a_crash", function()
  -- the kind comes from the runtime (lost = true), never from the reason's text
  local c = running(workers(pol("one_for_one", 3, 10, { "lost" })))
  c.sups["main.w"]:child_exit("b", "host h2 lost (daemon gone)")
  c:settle(c.t + 1)
  T.eq(c.outcome and c.outcome.path, "main.w.b", "a crash: the policy (on lost) does not take it")
  local c2 = running(workers(pol("one_for_one", 3, 10, { "crash" })))
  c2.sups["main.w"]:child_exit("b", "killed by SIGSEGV on host h2", true)
  c2:settle(c2.t + 1)
  T.eq(c2.outcome and c2.outcome.path, "main.w.b", "lost: the policy (on crash) does not take it")
end)

suite:case("a_lost_host_is_a_lost_fault", function()
  local c = running(workers(pol("one_for_one", 3, 10, { "lost" })))
  c:lose_host("h2")
  c:settle(c.t + 1)
  -- the restart on the same host fails (it is gone): the group escalates at once, naming it
  T.eq(c.outcome and c.outcome.type, "aborted")
  T.contains(c.outcome.reason, "restart of b failed: ")
  T.contains(c.outcome.reason, "host h2 unreachable")
end)

-- Three levels: main (h1) > mid (h2) > low (h3) > leaf; each level's budget is `n` restarts.
local function three_levels(n)
  local low = group("low", "Low", "h3", "leaf , other", { leaf("leaf", "Run", "h3"), leaf("other", "Run", "h3") })
  low.spec.supervision = pol("one_for_one", 2, 60)
  local mid = group("mid", "Mid", "h2", "low", { low })
  mid.spec.supervision = pol("one_for_one", n, 60)
  local spec = root("main", "h1", "mid", { mid })
  spec.supervision = pol("one_for_one", n, 60)
  return spec
end

suite:case("escalation_climbs_three_levels_and_the_root_names_the_first_cause", function()
  local c = running(three_levels(1))
  local kills = 0
  while not c.outcome and kills < 20 do
    T.ok(c:kill("main.mid.low.leaf", "SEGV"), "the leaf lives (kill " .. kills + 1 .. ")")
    kills = kills + 1
    c:settle(c.t + 1)
  end
  -- low gives up after 3 crashes; mid restarts it once, then gives up; main restarts mid once, then gives up
  T.eq(kills, 12)
  T.eq(c.outcome.type, "aborted")
  T.eq(c.outcome.path, "main.mid.low.leaf")
  T.eq(c.outcome.reason, "restart intensity 1 in 60 s exceeded; last: mid escalated: restart intensity 1 in 60 s "
    .. "exceeded; last: low escalated: restart intensity 2 in 60 s exceeded; last: leaf killed by SIGSEGV on host h3")
  T.eq(#lines(c, "^(main%.mid: restarted 1/1 in 60 s)"), 1)
  T.eq(#lines(c, "^(main%.mid%.low: restarted 1/1 in 60 s)"), 2)
  c:settle(c.t + 5)
end)

suite:case("a_restarted_sub_group_is_wired_again_by_the_group_above", function()
  -- main.src writes into main.g.x (a connection of main): after g's subtree restarts, the new x hears it
  local g = group("g", "G", "h2", "x", { leaf("x", "Run", "h2") }, {}, { { alias = "In", instance = "x", port = "In" } })
  local spec = root("main", "h1", "src[run] , g", { leaf("src", "Run", "h1"), g },
    { fake.set("src", "run", { { "src", "Out", "g", "In" } }) })
  spec.supervision = pol("one_for_one", 3, 10, { "crash", "lost", "aborted" })
  local c = running(spec)
  local before = pid(c, "main.g.x")
  c:node("main.g.x"):aborted("stuck")
  c:settle(c.t + 1)
  T.eq(c.outcome, nil)
  T.ok(pid(c, "main.g.x") ~= before, "a new subtree")
  T.eq(c:node("main.g.x").running, true)
  c:node("main.src"):write("Out", 5)
  c:settle(c.t + 1)
  T.eq(c:node("main.g.x").ports.In, 5, "the new leaf hears the writer of the group above")
end)

suite:case("restart_lines_go_up_with_the_fault_time_for_the_trace", function()
  -- a root asked for progress (dca run): its lines go up as `log {line, at}`; those of a restart carry the
  -- time of the event that caused it (dca run --trace keeps the lines that carry one)
  local spec = root("main", "h1", "a , b", { leaf("a", "Run", "h1"), leaf("b", "Run", "h1") })
  spec.supervision = pol("one_for_one", 3, 10, { "aborted" })
  local c = fake.cluster({ behave = {} })
  c:root(spec, { progress = true })
  assert(c:configure())
  c:start()
  c:settle(c.t + 1)
  c.root_sup:child_message("b", { type = "aborted", reason = "sensor fault", now = 2500000000 })
  c:settle(c.t + 1)
  local got = {}
  for _, m in ipairs(c.reports) do
    if m.type == "log" and m.line:find("restart") then got[#got + 1] = { m.line, m.at } end
  end
  T.eq(got, {
    { "main: one_for_one after b aborted: sensor fault: restarting b (1/3 in 10 s)", 2.5 },
    { "main.b: stopping to restart", 2.5 },   -- (an ABORTED leaf's process lives: stopped, then ended)
    { "main.b: restarted 1/3 in 10 s", 2.5 },
  })
  T.eq(c.outcome, nil)
end)

suite:case("tree_shows_the_policy_budget_and_restart_counts", function()
  local c = running(workers(pol("one_for_one", 3, 10)))
  c:kill("main.w.b", "SEGV")
  c:settle(c.t + 1)
  local tree
  c.root_sup:tree(function(t) tree = t end)
  c:settle(c.t, function() return tree ~= nil end)
  local w = tree.children[1]
  T.eq(w.policy, { strategy = "one_for_one", intensity = 3, within = 10, on = { crash = true, lost = true },
                   used = 1, total = 1, escalated = false })
  T.eq({ w.children[1].restarts, w.children[2].restarts }, { nil, 1 })
  local text = table.concat(require("dca.supervisor.console").render_tree(tree, {}), "\n")
  T.contains(text, "[one_for_one: 1/3 in 10 s used, 1 restarts]")
  T.ok(text:find("b%s+leaf%s.-running  restarted 1"), text)
end)

suite:case("a_silent_sub_supervisor_is_lost_and_its_subtree_restarted", function()
  local g = group("g", "G", "h2", "x", { leaf("x", "Run", "h2") })
  local spec = root("main", "h1", "g", { g })
  spec.supervision = pol("one_for_one", 3, 60, { "lost" })
  local c = fake.cluster({ behave = {}, heartbeat = { 1, 5 } })
  c:root(spec)
  assert(c:configure())
  c:start()
  c:settle(c.t + 1)
  local sup_pid, leaf_pid = pid(c, "main.g"), pid(c, "main.g.x")
  c:freeze("main.g")
  c:settle(c.t + 10, function() return #lines(c, "^(main%.g: restarted 1/3 in 60 s)") == 1 end)
  T.eq(#lines(c, "^(main%.g: lost: supervisor lost on host h2)"), 1)
  T.ok(pid(c, "main.g") ~= sup_pid and pid(c, "main.g.x") ~= leaf_pid, "a new supervisor and leaf")
  c:settle(c.t + 1)
  T.eq(c:node("main.g.x").running, true)
  T.eq(c.outcome, nil)
end)

suite:case("a_shutdown_during_a_restart_starts_nothing_more_and_reports_nothing", function()
  local c = running(workers(pol("one_for_all")))
  c.spawn_delay["main.w.b"] = 3
  c:kill("main.w.a", "SEGV")
  c:settle(c.t + 1)   -- a is up again, b's start waits
  local done = false
  c.root_sup:shutdown(function() done = true end)
  c:settle(c.t + 30, function() return done end)
  T.ok(done, "the shutdown ends")
  c:settle(c.t + 10)
  T.eq(c.outcome, nil, "no escalation reported")
  T.eq(c:alive(), {}, "nothing left")
end)

suite:case("a_reload_with_a_new_policy_applies_it_at_once", function()
  local c = running(workers(pol("one_for_one", 1, 60)))
  local w = c.sups["main.w"]
  local new = fake.copy(w.spec)
  new.supervision = pol("one_for_one", 5, 60)
  local got
  w:update(new, function(l) got = l end)
  c:settle(c.t, function() return got ~= nil end)
  T.eq(got, { "main.w (Workers): supervision policy changed; in effect now" })
  new = fake.copy(w.spec)
  new.hosts = { "h1", "h1b" }
  got = nil
  w:update(new, function(l) got = l end)
  c:settle(c.t, function() return got ~= nil end)
  T.eq(got, { "main.w (Workers): processes or connections changed; takes effect when the system is started again" })
  for _ = 1, 3 do
    c:kill("main.w.b", "SEGV")
    c:settle(c.t + 1)
  end
  T.eq(c.outcome, nil, "3 restarts within the new budget of 5")
  T.eq(#lines(c, "^(main%.w%.b: restarted %d/5 in 60 s)"), 3)
end)

suite:case("a_child_started_while_it_is_being_restarted_runs_once_it_is_up", function()
  -- `a ; b`: b crashes while it waits; a ends before b's new process is up: b runs once it is, no abort
  local c = running(workers(pol("one_for_one"), "a ; b"))
  c.spawn_delay["main.w.b"] = 2
  c:kill("main.w.b", "SEGV")
  c:node("main.w.a"):done(1)
  c:settle(c.t + 1)
  T.eq(c:node("main.w.b") and c:node("main.w.b").running, false, "not yet")
  T.eq(#lines(c, "^(main%.w%.b: running once restarted)"), 1)
  c:settle(c.t + 3)
  T.eq(c.outcome, nil, "the algebra saw nothing")
  T.eq(c:node("main.w.b").running, true, "b runs in its new process")
  c:node("main.w.b"):done(2)
  c:settle(c.t + 1)
  T.eq({ c.outcome.type, c.outcome.value }, { "done", 2 })
end)

suite:case("an_intensity_of_zero_gives_up_at_the_first_fault", function()
  local c = running(workers(pol("one_for_one", 0, 5)))
  c:kill("main.w.a", "SEGV")
  c:settle(c.t + 1)
  T.eq(c.outcome and c.outcome.reason, "restart intensity 0 in 5 s exceeded; last: a killed by SIGSEGV on host h1")
  T.eq(#lines(c, "(restarted)"), 0)
end)

suite:case("on_simulated_time_the_window_counts_the_events_time", function()
  -- a runtime in lock-step (rt.on_sim_time): the restarts are counted at their events' simulated time, not at
  -- the runtime's clock (which stands still here)
  local c = running(workers(pol("one_for_one", 1, 5, { "aborted" })))
  local w = c.sups["main.w"]
  w.rt.on_sim_time = function() return true end
  local function abort_at(s)
    w:child_message("b", { type = "aborted", reason = "stuck", now = math.floor(s * 1e9) })
    c:settle(c.t)
  end
  abort_at(1)
  abort_at(7)
  T.eq(c.outcome, nil, "6 s apart: one restart in each 5 s")
  abort_at(8)
  T.eq(c.outcome and c.outcome.reason, "restart intensity 1 in 5 s exceeded; last: b aborted: stuck")
end)

suite:case("an_escalation_drops_the_queued_faults_and_a_new_run_starts_their_children", function()
  -- b's restart fails while a's fault waits for it: the group escalates; a no longer waits for a restart, so
  -- when the same supervisor runs its expression again (restart(group) at the REPL) a is started, not parked
  local c = running(workers(pol("one_for_one", 3, 10)))
  local w = c.sups["main.w"]
  c.spawn_delay["main.w.b"] = 2
  c:kill("main.w.b", "SEGV")
  c:settle(c.t + 0.5)
  c:kill("main.w.a", "SEGV")
  c.fail_spawn["main.w.b"] = "no room"
  c:settle(c.t + 3)
  T.eq(w.escalated, true, table.concat(c.lines, "\n"))
  T.contains(w.outcome.reason, "restart of b failed")
  for name, ch in pairs(w.children) do T.eq(ch.policy_fault, nil, name .. " waits for no restart") end
  local from = #c.lines
  c.outcome = nil
  w:run_expr(nil)
  c:settle(c.t + 1)
  for i = from + 1, #c.lines do T.ok(not c.lines[i]:find("running once restarted"), c.lines[i]) end
  T.eq(w.outcome and w.outcome.status, "aborted", "the new run ends, no child left waiting")
  T.contains(w.outcome.reason, "is not running")
end)

suite:case("a_restarted_sub_group_gets_its_leaves_taps_again_inside_the_restart", function()
  -- main remembers the taps it made on a leaf below its sub-group low; low restarted whole (a fresh supervisor
  -- that remembers nothing) has them made again by main before its leaf runs again (lua.supervisor.taps.*)
  local low = group("low", "Low", "h2", "x", { leaf("x", "Run", "h2") })
  local spec = root("main", "h1", "low", { low })
  spec.supervision = pol("one_for_one", 3, 10, { "crash", "aborted" })
  local c = running(spec)
  local TAP = "tap:main.low.x.Out"
  c.root_sup:to_leaf("main.low.x", { type = "connect", set = TAP, out = "Out", to = "rec", ["in"] = "x", stamped = true })
  c.root_sup:to_leaf("main.low.x", { type = "activate", set = TAP })
  c:settle(c.t + 1)
  local from = #c.commands
  c:kill("main.low.x", "SEGV")
  c:settle(c.t + 1)
  T.eq(#lines(c, "^(main%.low: restarted 1/3 in 10 s)"), 1)
  local after = {}
  for i = from + 1, #c.commands do
    local cmd = c.commands[i]
    if cmd:find("^main%.low%.x ") and (cmd:find(TAP, 1, true) or cmd:find(" run$")) then after[#after + 1] = cmd end
  end
  T.eq(after, { "main.low.x connect " .. TAP, "main.low.x activate " .. TAP, "main.low.x run" })
  T.eq(c:node("main.low.x").active[TAP], true)
end)

suite:case("the_leaves_of_one_shared_node_ended_together_are_one_fault", function()
  -- a shared node's crash ends its leaves together (children_exit with several names): one restart counted
  local c = running(workers(pol("one_for_one", 3, 10)))
  local w = c.sups["main.w"]
  local before = pids(c, ABC)
  for _, p in ipairs(c.procs) do
    if p.path == "main.w.a" or p.path == "main.w.c" then p.alive = false end
  end
  w:children_exit({ "c", "a" }, "killed by SIGSEGV on host h1 (shared node leaves:main.w@h1#7, 2 leaves)")
  c:settle(c.t + 1)
  T.eq(lines(c, "^main%.w: one_for_one after c killed by SIGSEGV on host h1 %(shared node [^)]*%): restarting (.*)$"),
       { "a, c (1/3 in 10 s)" }, "one fault, the children in start order")
  local now = pids(c, ABC)
  T.ok(now["main.w.a"] ~= before["main.w.a"] and now["main.w.c"] ~= before["main.w.c"])
  T.eq(now["main.w.b"], before["main.w.b"])
  T.eq(w:policy_status().used, 1)
  T.eq(c.outcome, nil)
end)

return suite:run(...)
