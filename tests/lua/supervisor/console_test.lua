-- The console inside a supervisor (dca.supervisor.console) and reload (Sup:update), on the in-memory cluster.
local T, fake = require "dca.testing", require "dca.supervisor.memory"
local suite = T.suite("supervisor_console")

local leaf, group, root, set = fake.leaf, fake.group, fake.root, fake.set
local behave = {
  Threshold = function(n) n:after(2, function() n:done(1.5) end) end,
}

local function system()
  local hitg = group("hitg", "HitDetector", "h3", "hit # (ft[l], comp)", {
    leaf("ft", "ForceTorque", "h3"), leaf("comp", "CompliantCtrl", "h3"), leaf("hit", "Worker", "h3"),
  }, { set("ft", "l", { { "ft", "Out", "hit", "In" } }) })
  return root("main", "h1", "mc , hitg", { leaf("mc", "Worker", "h2"), hitg })
end

-- Evaluates `line` in the root's console and settles the cluster until it answered.
local function eval(c, repl, line)
  local out, more
  repl:eval(line, function(o, m) out, more = o, m end)
  c:settle(nil, function() return out ~= nil end)
  return out, more
end

local function running_system()
  local c = fake.cluster{ behave = behave }
  local sup = c:root(system())
  assert(c:configure())
  c:start()
  c:settle(1)
  return c, require("dca.supervisor.console").new(sup)
end

suite:case("expressions_print_like_the_lua_console_and_statements_run", function()
  local c, repl = running_system()
  for _, e in ipairs({ { "1 + 2", "3" }, { "x = 41", "" }, { "x + 1", "42" }, { "'a', 2", "a\t2" } }) do
    T.eq(eval(c, repl, e[1]), e[2], e[1])
  end
end)

-- `help` typed without parentheses prints the commands (as `tree`, `log`, ...: the commands that only show); a
-- command that acts, typed bare, gets a hint and does nothing; a variable of that name is still a variable.
suite:case("a_bare_help_prints_the_commands_and_a_bare_action_gets_a_hint", function()
  local c, repl = running_system()
  T.contains(eval(c, repl, "help"), "help()                        this text")
  T.contains(eval(c, repl, " tree "), "main")
  T.eq(eval(c, repl, "abort"), "abort is a command: type abort(...) (help() lists the commands)")
  T.eq(c.root_sup.state, "running")
  T.eq(eval(c, repl, "x = 3"), "")
  T.eq(eval(c, repl, "x"), "3")
end)

-- The simulated clock's commands (docs/time.md "Pace") ask the clock master through the supervisor's `clock`
-- request: here a stand-in for the world's (hold, go, step, pace, status) whose step takes effect at the status
-- after it, as a tick after the request. Typed bare, clock/pause/resume/step run; a bad speed is refused before
-- the world is asked.
suite:case("the_clock_commands_ask_the_clock_master_and_check_the_speed", function()
  local c, repl = running_system()
  local w, asked = { t = 2.0, running = true, speed = 1, stepping = false }, {}
  c.root_sup.clock_hook = function(req, cb)
    asked[#asked + 1] = req.type .. (req.to and (" " .. req.to) or "") .. (req.speed and (" " .. req.speed) or "")
    if req.type == "hold" then w.running = false
    elseif req.type == "go" then w.running = true
    elseif req.type == "pace" then w.speed = req.speed
    elseif req.type == "step" then w.running, w.stepping, w.tick = true, true, req.to == "tick"
    elseif req.type == "status" and w.tick then  -- the step's tick, then time holds
      w.t, w.stepping, w.running, w.tick = w.t + 0.001, false, false, false
      cb({ t = w.t, running = true, speed = w.speed, stepping = true }) return
    end
    cb({ t = w.t, running = w.running, speed = w.speed, stepping = w.stepping })
  end
  T.eq(eval(c, repl, "clock"), "t = 2.000 s, running at 1x")
  T.eq(eval(c, repl, "pause"), "t = 2.000 s, paused")
  T.eq(eval(c, repl, "step"), "t = 2.001 s, paused")
  T.eq(eval(c, repl, "step()"), "t = 2.002 s, paused")
  T.eq(eval(c, repl, "speed(0.5)"), "t = 2.002 s, paused")
  T.contains(eval(c, repl, "speed(11)"), "speed: 0.1 to 10 (times real time), or \"max\"")
  T.contains(eval(c, repl, "step('x')"), "step(): one tick")
  T.eq(eval(c, repl, "speed('max')"), "t = 2.002 s, paused")
  T.eq(eval(c, repl, "resume"), "t = 2.002 s, running at max speed")
  T.eq(eval(c, repl, "step('event')"), "t = 2.002 s, running at max speed, stepping")
  T.eq(asked, { "status", "hold", "status", "step tick", "status", "status", "step tick", "status", "status",
                "pace 0.5", "status", "pace 0", "status", "go", "status", "step event", "status" })
  c.root_sup.clock_hook = nil
  T.contains(eval(c, repl, "clock()"), "clock: ")  -- (the in-memory cluster has no world: why, said)
end)

suite:case("an_incomplete_chunk_waits_for_more_lines", function()
  local c, repl = running_system()
  local out, more = eval(c, repl, "function f(a)")
  T.eq(more, true)
  T.eq(out, "")
  T.eq(select(2, eval(c, repl, "return a * 2")), true)
  T.eq(select(2, eval(c, repl, "end")), false)
  T.eq(eval(c, repl, "f(21)"), "42")
end)

suite:case("errors_print_and_keep_the_console_and_the_system_alive", function()
  local c, repl = running_system()
  for _, e in ipairs({ { "error('boom')", "boom" }, { "1 +* 2", "unexpected symbol" },
                       { "status('nosuch')", "no process 'nosuch'" } }) do
    T.contains(eval(c, repl, e[1]), e[2])
  end
  T.eq(eval(c, repl, "2 * 2"), "4")
  T.eq(c.root_sup.state, "running")
end)

suite:case("tree_shows_every_process_with_state_and_host_across_supervisors", function()
  local c, repl = running_system()
  local out = eval(c, repl, "tree()")
  T.contains(out, "main")
  T.contains(out, "hitg")
  T.contains(out, "HitDetector@h3")
  T.contains(out, "ft ")
  T.contains(out, "ForceTorque@h3")
  T.contains(out, "running")
  T.contains(eval(c, repl, "status('hitg.ft')"), "main.hitg.ft: leaf ForceTorque on host h3, running")
  T.contains(eval(c, repl, "expr('hitg')"), "*hit*")
end)

suite:case("event_injection_reaches_the_owner_and_ends_the_group", function()
  local c, repl = running_system()
  T.contains(eval(c, repl, "event('hitg.hit', 'done', 7)"), "main.hitg.hit: done injected")
  c:settle(2)
  T.eq(c:node("main.hitg.ft").running, false, "ft aborted by hit's DONE")
  T.eq(c.sups["main.hitg"].outcome, { status = "done", value = 7 })
  T.contains(eval(c, repl, "abort('mc')"), "aborted injected")
  T.eq(c:outcome_within(10).type, "aborted")
  T.eq(c.outcome.path, "main.mc")
end)

suite:case("abort_of_the_group_itself_ends_it_aborted_and_its_outcome_goes_up", function()
  -- abort() at the root's console: the root's ABORTED reaches its parent (under `dca run`: the run ends 1);
  -- abort() of a sub-group at its own console: its parent's algebra sees the group end
  local c, repl = running_system()
  T.contains(eval(c, repl, "abort()"), "main: aborted")
  local out = c:outcome_within(10)
  T.eq(out and out.type, "aborted")
  T.eq(out.path, "main")
  T.eq(out.reason, "aborted from the REPL")
  T.eq(c:node("main.mc").running, false, "mc stopped")
  local c2 = running_system()
  local hit_repl = require("dca.supervisor.console").new(c2.sups["main.hitg"])
  T.contains(eval(c2, hit_repl, "abort()"), "main.hitg: aborted")
  local out2 = c2:outcome_within(10)
  T.eq(out2 and out2.type, "aborted", "main's `mc , hitg` ends ABORTED with hitg")
  T.eq(out2.path, "main.hitg")
end)

suite:case("activate_and_deactivate_switch_a_set_at_its_source_node", function()
  local c, repl = running_system()
  local ft = c:node("main.hitg.ft")
  T.ok(ft.active["main.hitg:ft[l]"], "active while ft[l] runs")
  T.contains(eval(c, repl, "deactivate('hitg.ft', 'l')"), "deactivated")
  c:settle(1.5)
  T.eq(ft.active["main.hitg:ft[l]"], nil)
  T.contains(eval(c, repl, "activate('hitg.ft', 'nolabel')"), "no connection set main.hitg:ft[nolabel]")
end)

suite:case("log_shows_recent_events_and_completion_offers_commands_and_paths", function()
  local c, repl = running_system()
  T.contains(eval(c, repl, "log(50)"), "main.mc: running")
  local cands = repl:complete("hitg.f")
  T.eq(cands, { "hitg.ft" })
  T.ok(#repl:complete("tre") >= 1 and repl:complete("tre")[1] == "tree")
  T.eq(repl:complete("config.w"), { "config.watch" })
  T.eq(repl:complete("config.l"), { "config.list", "config.log" })
  -- without a repository (the in-memory runtime) config says so and the console goes on
  T.contains(eval(c, repl, "config.get('door.width')"), "no configuration repository")
end)

suite:case("reload_of_event_actions_takes_effect_at_the_next_start_and_restart_applies_it_now", function()
  local c, repl = running_system()
  local new = system()
  new.children[2].spec.expr = "hit # ft[l]"
  local lines
  c.root_sup:update(new, function(l) lines = l end)
  c:settle(nil, function() return lines ~= nil end)
  T.eq(#lines, 1)
  T.contains(lines[1], "main.hitg (HitDetector): event actions changed; takes effect at next start")
  T.ok(c:node("main.hitg.comp").running, "the running expression is untouched")
  T.contains(eval(c, repl, "restart('hitg')"), "main.hitg: restarted")
  c:settle(3)
  T.eq(c:node("main.hitg.comp").running, false, "comp is not in the new expression")
  T.ok(c:node("main.hitg.ft").running)
  T.contains(eval(c, repl, "expr('hitg')"), "*hit* # *ft[l]*")
end)

suite:case("a_structural_change_is_reported_not_applied", function()
  local c = fake.cluster{ behave = behave }
  local sup = c:root(system())
  assert(c:configure())
  local new = system()
  new.children[1].type = "Other"
  local lines
  sup:update(new, function(l) lines = l end)
  c:settle(nil, function() return lines ~= nil end)
  T.contains(lines[1], "main (main): processes or connections changed")
  T.eq(sup.spec.children[1].type, "Worker")
end)

-- The monitor's config_set request (dca.supervisor.requests): a value written to the repository; without one (the
-- in-memory runtime) an error that says so, never an ok; a malformed request is refused with its reason.
suite:case("config_set_requests_are_answered_with_the_repositorys_verdict", function()
  local c = fake.cluster{ behave = behave }
  local sup = c:root(system())
  assert(c:configure())
  local requests = require "dca.supervisor.requests"
  local got
  requests.handle(sup, { type = "config_set", key = "door.width", value = 0.9 }, function(r) got = r end)
  T.eq(got, { type = "error", reason = "main has no configuration repository" })
  requests.handle(sup, { type = "config_set" }, function(r) got = r end)
  T.eq(got.type, "error")
  T.contains(got.reason, "a key")
  -- a repository that refuses the key: its reason, not ok
  local written
  sup.rt.config_client = function(k)
    k({ set = function(_, values, cb)
      if values["door.bad"] then cb(nil, "unknown key 'door.bad' (did you mean door.width?) on host h1") return end
      written = values
      cb({ keys = 1, seq = 7, origin = "h1" })
    end })
  end
  requests.handle(sup, { type = "config_set", key = "door.bad", value = 1 }, function(r) got = r end)
  T.eq(got, { type = "error", reason = "unknown key 'door.bad' (did you mean door.width?) on host h1" })
  requests.handle(sup, { type = "config_set", key = "door.width", value = 0.9 }, function(r) got = r end)
  T.eq(got, { type = "ok", text = "set 1 key: transaction 7 of h1" })
  T.eq(written, { ["door.width"] = 0.9 })
  -- a console request like the others (the monitor's commands go through this gate in `dca run`)
  got = nil
  local ch = { reply = function(_, _, r) r.type = r.type or "ok" got = r return true end,
               reply_error = function(_, _, reason) got = { type = "error", reason = reason } return true end }
  require("dca.supervisor.net").console(ch, 1, { type = "config_set", key = "door.width", value = 0.8 }, sup, {})
  T.eq(got, { type = "ok", text = "set 1 key: transaction 7 of h1" })
  T.eq(written, { ["door.width"] = 0.8 })
end)

suite:case("stats_show_each_timer_with_the_period_it_achieved", function()
  local console = require "dca.supervisor.console"
  local summary = function(p50, p99, max) return { n = 99, p50_us = p50, p99_us = p99, max_us = max } end
  local text = console.format_stats("main.pid", { clock = "sim",
    timers = { { name = "main.pid", period_s = 0.01, active = true, count = 100, missed = 2, p50_us = 3,
                 p99_us = 12.4, max_us = 1500 },
               { name = "main.pid.once", period_s = 0, active = false, count = 1, missed = 0, p50_us = 0,
                 p99_us = 0, max_us = 0 } },
    intervals = { { name = "main.pid", period_s = 0.01, clock = summary(10000, 10000, 20000),
                    wall = summary(980, 2500, 1250000) } } })
  T.eq(text, "main.pid (sim clock):\n" ..
    "  main.pid every 10.000 ms: 100 ticks, late p50 3 us p99 12 us max 1.500 ms, overruns 2\n" ..
    "    period achieved p50 10.000 ms p99 10.000 ms max 20.000 ms; on the wall clock p50 980 us p99 2.500 ms max 1.250 s\n" ..
    "  main.pid.once once (stopped): 1 ticks, late p50 0 us p99 0 us max 0 us, overruns 0")
  T.eq(console.format_stats("main.x", { clock = "wall" }), "main.x (wall clock):\n  no timers")
end)

suite:case("stats_of_a_leaf_on_a_real_time_thread_show_its_wake_latency_and_execution_time", function()
  local console = require "dca.supervisor.console"
  local text = console.format_stats("main.pid", { clock = "wall", timers = {}, intervals = {},
    rt = { thread = 4242, runs = 1000, overruns = 1, missed = 3, period_s = 0.001,
           wake = { n = 1000, p50_us = 27, p99_us = 54, p999_us = 80, max_us = 950 },
           exec = { n = 1000, p50_us = 2, p99_us = 4, p999_us = 9, max_us = 1200 }, dropped = 0 } })
  T.eq(text, "main.pid (wall clock):\n" ..
    "  real-time thread 4242: 1000 runs every 1.000 ms, overruns 1 (periods missed 3)\n" ..
    "    wake latency p50 27 us p99 54 us p99.9 80 us max 950 us; execution p50 2 us p99 4 us max 1.200 ms")
end)

suite:case("read_asks_a_leafs_node_and_refuses_a_group", function()
  local c, repl = running_system()
  T.eq(eval(c, repl, 'read("mc", "Out")'), "nil\t(0 samples)")
  T.contains(eval(c, repl, 'read("hitg", "Out")'), "main.hitg is a group: read asks a leaf")
  T.contains(eval(c, repl, 'read("mc")'), "read(path, port): the port's name")
  T.contains(eval(c, repl, 'read("nosuch", "Out")'), "no process 'nosuch'")
end)

return suite:run(...)
