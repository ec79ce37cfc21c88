-- A fleet (dca.supervisor.fleet; docs/supervision.md, "A fleet"): a template's instances added and removed while
-- the system runs, on the in-memory cluster in simulated time, from a .dca file through dca.lang.model and
-- dca.supervisor.spec as `dca run` takes it. Counter leaves tick until stopped, Timer leaves end DONE after their
-- time. Instances are supervised by the group's policy as the first ones are, a crashed one restarted, past the
-- intensity the group escalates, and a restarted parent group brings its instances up again.
local T = require "dca.testing"
local fake = require "dca.supervisor.memory"
local parser = require "dca.lang.parser"
local model = require "dca.lang.model"
local spec_mod = require "dca.supervisor.spec"
local suite = T.suite("fleet")

local SYSTEM = [[
process Light(h, period) {
  instantiated_processes { c instof Counter(h, period); }
  internal_event_actions { c }
}
process Fleet(h) {
  host { h }
  supervision { strategy one_for_one; intensity 2 in 10 s; restart on crash, lost; }
  instantiated_processes {
    door instof Counter(h, 0.1);
    lights instances of Light(0.5) on { "r1", "r2", "r3" };
    timers instances of Timer(5) on { "r1", "r2" };
  }
  internal_event_actions { door }
}
process main() {
  supervision { strategy one_for_one; intensity 3 in 10 s; restart on crash, lost; }
  instantiated_processes { fleet instof Fleet("base"); }
  internal_event_actions { fleet }
}
]]

local function spec_of(text)
  local ast = assert(parser.parse(text, "fleet.dca"))
  local tree, errs = model.build(ast, {})
  assert(tree, errs and errs[1] and errs[1].msg)
  return spec_mod.from_model(tree, "fleet.dca")
end

local BEHAVE = {
  Counter = function(node) node:every(0.5, function() end) end,
  Timer = function(node) node:after(node.args and node.args[1] or 5, function() node:done("timeout") end) end,
}

local function running(text)
  local c = fake.cluster({ behave = BEHAVE })
  c:root(spec_of(text or SYSTEM))
  assert(c:configure())
  c:start()
  c:settle(c.t + 1)
  return c
end

-- add_child / remove_child asked of the root, as the REPL does; the answer once the cluster settles.
local function ask(c, what, path, host)
  local res
  c.root_sup[what](c.root_sup, path, host, function(ok, r) res = { ok, r } end)
  c:settle(c.t + 1, function() return res ~= nil end)
  assert(res, what .. " did not answer")
  c:settle(c.t)   -- (what the answer set going: a run below, without time passing)
  return res[1], res[2]
end

local function pid(c, path)
  for _, p in ipairs(c.procs) do if p.path == path and p.alive then return p.pid end end
end

local function alive(c, prefix)
  local out = {}
  for _, p in ipairs(c:alive()) do if p:sub(1, #prefix) == prefix then out[#out + 1] = p end end
  table.sort(out)
  return out
end

local function said(c, pattern)
  for _, l in ipairs(c.lines) do if l:find(pattern) then return l end end
end

suite:case("the_spec_holds_one_prepared_instance_per_host_and_none_runs_at_start", function()
  local spec = spec_of(SYSTEM)
  local fleet = spec.children[1].spec
  T.eq(#fleet.children, 1, "only the door is a child at start")
  T.eq(fleet.templates[1].hosts, { "r1", "r2", "r3" })
  T.eq(fleet.templates[1].instances[2].name, "lights_r2")
  T.eq(fleet.templates[1].instances[2].spec.host, "r2", "a group instance's supervisor runs on its host")
  T.eq(fleet.templates[2].instances[1].args, { 5 }, "a leaf instance: the written arguments after its host")
  T.eq(spec_mod.hosts(spec), { "base", "r1", "r2", "r3" }, "every template host gets a daemon")
  local c = running()
  T.eq(alive(c, "main.fleet.lights"), {})
end)

suite:case("instances_are_added_run_and_removed_while_the_system_runs", function()
  local c = running()
  local ok, path = ask(c, "add_child", "main.fleet.lights", "r1")
  T.eq({ ok, path }, { true, "main.fleet.lights_r1" })
  T.ok(ask(c, "add_child", "main.fleet.lights", "r2"))
  T.eq(alive(c, "main.fleet.lights"), { "main.fleet.lights_r1", "main.fleet.lights_r1.c", "main.fleet.lights_r2",
                                        "main.fleet.lights_r2.c" })
  T.eq(c:node("main.fleet.lights_r2.c").running, true, "an added instance runs at once")
  T.eq(c:node("main.fleet.lights_r2.c").host, "r2")
  -- the tree shows them, with the template
  local tree
  c.root_sup:tree(function(t) tree = t end)
  c:settle(c.t + 1, function() return tree ~= nil end)
  local f = require("dca.supervisor").find(tree, "main.fleet")
  T.eq(f.fleet[1].template, "lights")
  T.eq(#f.fleet[1].instances, 2)
  T.eq(require("dca.supervisor").find(tree, "main.fleet.lights_r2.c").state, "running")
  -- removed: stopped (actuators at zero) and its processes gone; the rest runs on
  T.eq({ ask(c, "remove_child", "main.fleet.lights_r1") }, { true, "main.fleet.lights_r1" })
  T.eq(alive(c, "main.fleet.lights"), { "main.fleet.lights_r2", "main.fleet.lights_r2.c" })
  -- by template and host too, then added again
  T.ok(ask(c, "remove_child", "main.fleet.lights", "r2"))
  T.eq(alive(c, "main.fleet.lights"), {})
  T.ok(ask(c, "add_child", "main.fleet.lights", "r1"))
  T.eq(c:node("main.fleet.lights_r1.c").running, true)
  T.eq(c.outcome, nil, "the task carries on")
end)

suite:case("refusals_name_the_template_and_its_hosts", function()
  local c = running()
  local ok, why = ask(c, "add_child", "main.fleet.lights", "r9")
  T.eq(ok, nil)
  T.eq(why, "main.fleet.lights: host r9 is not one of its hosts (r1, r2, r3)")
  T.ok(ask(c, "add_child", "main.fleet.lights", "r1"))
  ok, why = ask(c, "add_child", "main.fleet.lights", "r1")
  T.eq({ ok, why }, { nil, "main.fleet.lights already has an instance on host r1: main.fleet.lights_r1" })
  ok, why = ask(c, "add_child", "main.fleet.door", "r1")
  T.eq({ ok, why }, { nil, "main.fleet.door is a leaf, not a template" })
  ok, why = ask(c, "remove_child", "main.fleet.lights_r3")
  T.eq({ ok, why }, { nil, "main.fleet: no instance main.fleet.lights_r3" })
  c.fail_spawn["main.fleet.timers_r2"] = "no such program"
  ok, why = ask(c, "add_child", "main.fleet.timers", "r2")
  T.eq(ok, nil)
  T.contains(why, "no such program")
  T.ok(said(c, "main.fleet.timers_r2: not added"), "said")
  c.fail_spawn["main.fleet.timers_r2"] = nil
  T.ok(ask(c, "add_child", "main.fleet.timers", "r2"), "added once it can start")
end)

suite:case("a_crashed_instance_is_restarted_by_the_group_policy_like_the_first", function()
  local c = running()
  T.ok(ask(c, "add_child", "main.fleet.lights", "r1"))
  T.ok(ask(c, "add_child", "main.fleet.lights", "r3"))
  local before = { pid(c, "main.fleet.lights_r1"), pid(c, "main.fleet.lights_r3") }
  c:kill("main.fleet.lights_r3", "SEGV")
  c:settle(c.t + 2)
  T.eq(c.outcome, nil, "the algebra saw nothing")
  local now = { pid(c, "main.fleet.lights_r1"), pid(c, "main.fleet.lights_r3") }
  T.eq(now[1], before[1], "one_for_one: the other instance untouched")
  T.ok(now[2] and now[2] ~= before[2], "the crashed instance is a fresh supervisor")
  T.eq(c:node("main.fleet.lights_r3.c").running, true, "and runs again")
  T.ok(said(c, "main.fleet: one_for_one after lights_r3 killed by SIGSEGV"), "the policy's line")
  -- a leaf instance too
  T.ok(ask(c, "add_child", "main.fleet.timers", "r1"))
  c:kill("main.fleet.timers_r1", "KILL")
  c:settle(c.t + 0.5)
  T.eq(c:node("main.fleet.timers_r1").running, true, "the leaf instance runs again")
end)

suite:case("past_the_intensity_instances_escalate_the_group", function()
  local c = running()
  T.ok(ask(c, "add_child", "main.fleet.lights", "r1"))
  for _ = 1, 3 do
    c:kill("main.fleet.lights_r1", "SEGV")
    c:settle(c.t + 0.5)
  end
  T.ok(said(c, "main%.fleet: restart intensity 2 in 10 s exceeded; last: lights_r1 killed by SIGSEGV"), "escalated")
  -- the parent's policy restarts the fleet as a crash of that child: it comes up with the instance it had
  c:settle(c.t + 1)
  T.eq(c.outcome, nil)
  T.eq(c:node("main.fleet.lights_r1.c").running, true, "the restarted fleet brought its instance up again")
  T.eq(c:node("main.fleet.door").running, true)
end)

suite:case("an_instance_that_ends_leaves_the_group_running", function()
  local c = running()
  T.ok(ask(c, "add_child", "main.fleet.timers", "r2"))
  c:settle(c.t + 6)
  T.ok(said(c, "main%.fleet%.timers_r2: done \"timeout\" %(its instance ends; the group runs on%)"), "said")
  T.eq(c.outcome, nil)
  T.eq(c:node("main.fleet.door").running, true)
  -- an instance ended is removed by hand, its process gone
  T.ok(ask(c, "remove_child", "main.fleet.timers_r2"))
  T.eq(alive(c, "main.fleet.timers"), {})
end)

suite:case("the_group_run_ending_stops_its_instances_before_its_outcome", function()
  local text = SYSTEM:gsub('door instof Counter%(h, 0.1%)', 'door instof Timer(h, 3)')
  local c = running(text)
  T.ok(ask(c, "add_child", "main.fleet.lights", "r1"))
  local o = c:outcome_within(c.t + 5)
  T.eq(o and o.type, "done")
  T.eq(c:node("main.fleet.lights_r1.c").running, false, "stopped: actuators at zero before the outcome")
end)

suite:case("a_restarted_group_brings_up_the_instances_it_had", function()
  local c = running()
  T.ok(ask(c, "add_child", "main.fleet.lights", "r2"))
  T.ok(ask(c, "add_child", "main.fleet.timers", "r1"))
  T.ok(ask(c, "remove_child", "main.fleet.timers_r1"))
  local old = pid(c, "main.fleet")
  c:kill("main.fleet", "SEGV")
  c:settle(c.t + 2)
  T.ok(pid(c, "main.fleet") ~= old, "a fresh fleet supervisor")
  T.eq(alive(c, "main.fleet.lights"), { "main.fleet.lights_r2", "main.fleet.lights_r2.c" })
  T.eq(alive(c, "main.fleet.timers"), {}, "a removed instance stays removed")
  T.eq(c:node("main.fleet.lights_r2.c").running, true)
end)
-- The REPL's verbs (dca.supervisor.console): add_child, remove_child and fleet(), paths by unique suffix.
suite:case("the_console_adds_lists_and_removes_instances", function()
  local c = running()
  local repl = require("dca.supervisor.console").new(c.root_sup)
  local function eval(line)
    local out
    repl:eval(line, function(o) out = o end)
    c:settle(c.t + 1, function() return out ~= nil end)
    c:settle(c.t)
    return out
  end
  T.eq(eval('add_child("lights", "r2")'), "main.fleet.lights_r2: added on host r2")
  T.eq(eval('add_child("fleet.timers", "r1")'), "main.fleet.timers_r1: added on host r1")
  T.eq(eval("fleet"), "main.fleet.lights: Light on { r1, r2, r3 }: main.fleet.lights_r2 on r2 (running)\n"
    .. "main.fleet.timers: Timer on { r1, r2 }: main.fleet.timers_r1 on r1 (running)")
  T.contains(eval("tree()"), "lights_r2")
  T.contains(eval("tree()"), "timers")
  T.contains(eval('add_child("lights", "r7")'), "main.fleet.lights: host r7 is not one of its hosts (r1, r2, r3)")
  T.contains(eval('add_child("lights")'), "the host is a string")
  T.eq(eval('remove_child("lights_r2")'), "main.fleet.lights_r2: removed")
  T.eq(eval('remove_child("timers", "r1")'), "main.fleet.timers_r1: removed")
  T.eq(eval("fleet('fleet')"), "main.fleet.lights: Light on { r1, r2, r3 }: no instance\n"
    .. "main.fleet.timers: Timer on { r1, r2 }: no instance")
  T.eq(eval("remove_child"), "remove_child is a command: type remove_child(...) (help() lists the commands)")
end)

-- A reload of the same file (Sup:update) is no change of processes: the added instances are the fleet's.
suite:case("a_reload_of_the_same_file_keeps_the_instances_and_says_no_change", function()
  local c = running()
  T.ok(ask(c, "add_child", "main.fleet.lights", "r1"))
  local lines
  c.root_sup:update(spec_of(SYSTEM), function(l) lines = l end)
  c:settle(c.t + 1, function() return lines ~= nil end)
  T.eq(lines, {})
  T.eq(c:node("main.fleet.lights_r1.c").running, true)
end)

-- A robot switched off (its host lost): with `restart on crash` only, the loss is no fault of the policy's, so it
-- ends that instance only and the group runs on; with `lost` too, its restart on the lost host fails and the
-- group escalates (as any child without a standby host): docs/supervision.md, "A fleet".
suite:case("a_lost_robot_ends_its_instance_when_the_policy_restarts_crashes_only", function()
  local text = SYSTEM:gsub("restart on crash, lost; }\n  instantiated_processes {\n    door",
                           "restart on crash; }\n  instantiated_processes {\n    door")
  assert(text ~= SYSTEM)
  local c = running(text)
  T.ok(ask(c, "add_child", "main.fleet.lights", "r1"))
  T.ok(ask(c, "add_child", "main.fleet.lights", "r2"))
  c:lose_host("r2")
  c:settle(c.t + 1)
  T.ok(said(c, "main%.fleet%.lights_r2: lost: .*not restarted: its instance ends; the group runs on"), "said")
  T.eq(c.outcome, nil)
  T.eq(c:node("main.fleet.lights_r1.c").running, true)
  T.eq(c:node("main.fleet.door").running, true)
  T.ok(ask(c, "remove_child", "main.fleet.lights_r2"), "and removed by hand")
end)

-- Escalated without a parent's policy: the group's running instances are stopped with its other children, before
-- its outcome goes up.
suite:case("an_escalated_group_stops_its_instances_before_its_outcome", function()
  local text = SYSTEM:gsub("process main%(%) {\n  supervision {[^\n]*\n", "process main() {\n")
  assert(text ~= SYSTEM)
  local c = running(text)
  T.ok(ask(c, "add_child", "main.fleet.lights", "r1"))
  T.ok(ask(c, "add_child", "main.fleet.lights", "r2"))
  for _ = 1, 3 do
    c:kill("main.fleet.lights_r1", "SEGV")
    c:settle(c.t + 0.5)
  end
  local o = c:outcome_within(c.t + 5)
  T.eq(o and o.type, "aborted")
  T.contains(o.reason, "restart intensity 2 in 10 s exceeded")
  T.eq(c:node("main.fleet.lights_r2.c").running, false, "the other instance was stopped")
  T.eq(c:node("main.fleet.door").running, false)
end)

-- A group whose run has ended (DONE) takes no new instance; a template whose type fixes its own host still adds
-- one per host of its set (the i-th prepared instance is the i-th host's).
suite:case("no_add_once_the_group_run_ended_and_instances_found_by_host", function()
  local text = SYSTEM:gsub('door instof Counter%(h, 0.1%)', 'door instof Timer(h, 3)')
                     :gsub("process Light%(h, period%) {\n", 'process Light(h, period) {\n  host { "base" }\n')
  local c = running(text)
  T.ok(ask(c, "add_child", "main.fleet.lights", "r2"))
  T.eq(c.procs[#c.procs].host, "r2", "its leaf on r2 (its supervisor on base, as its host { } says)")
  c:outcome_within(c.t + 5)
  local ok, why = ask(c, "add_child", "main.fleet.lights", "r3")
  T.eq({ ok, why }, { nil, "main.fleet.lights: cannot add an instance while its group is done" })
end)

-- one_for_all: a crashed instance restarts every child of the group, the declared door and the other instances
-- alike (stopped newest first, started in order: the door, then the instances in the order they were added).
suite:case("one_for_all_restarts_the_instances_with_the_declared_children", function()
  local text = SYSTEM:gsub("supervision { strategy one_for_one; intensity 2", "supervision { strategy one_for_all; intensity 2")
  assert(text ~= SYSTEM)
  local c = running(text)
  T.ok(ask(c, "add_child", "main.fleet.lights", "r3"))
  T.ok(ask(c, "add_child", "main.fleet.lights", "r1"))
  local before = { pid(c, "main.fleet.door"), pid(c, "main.fleet.lights_r3"), pid(c, "main.fleet.lights_r1") }
  c:kill("main.fleet.lights_r1", "SEGV")
  c:settle(c.t + 2)
  local now = { pid(c, "main.fleet.door"), pid(c, "main.fleet.lights_r3"), pid(c, "main.fleet.lights_r1") }
  for i = 1, 3 do T.ok(now[i] and now[i] ~= before[i], "a fresh process " .. i) end
  T.ok(said(c, "main%.fleet: one_for_all after lights_r1 killed by SIGSEGV on host r1: restarting door, lights_r3, "
    .. "lights_r1 %(1/2"), "the plan: the door, then the instances in the order added")
  T.eq({ c:node("main.fleet.door").running, c:node("main.fleet.lights_r3.c").running,
         c:node("main.fleet.lights_r1.c").running }, { true, true, true })
  T.eq(c.outcome, nil)
end)

-- Each change is recorded in the configuration repository before it is answered: `fleet.PATH`, the hosts with an
-- instance in the order they joined and the change, one write each, in the order of the changes.
suite:case("each_change_is_recorded_in_the_configuration_repository_before_its_answer", function()
  local c = fake.cluster({ behave = BEHAVE, config = {} })
  c:root(spec_of(SYSTEM))
  assert(c:configure())
  c:start()
  c:settle(c.t + 1)
  local writes = {}
  local set = c.config_set
  function c.config_set(self, values)
    writes[#writes + 1] = values
    return set(self, values)
  end
  local function answered(what, path, host)
    local n, res = #writes, nil
    c.root_sup[what](c.root_sup, path, host, function(ok, r) res = { ok, r, #writes } end)
    c:settle(c.t + 1, function() return res ~= nil end)
    T.ok(res and res[1], tostring(res and res[2]))
    T.eq(res[3], n + 1, what .. " " .. path .. ": one write, made before the answer")
    c:settle(c.t)
  end
  answered("add_child", "main.fleet.lights", "r2")
  answered("add_child", "main.fleet.lights", "r1")
  answered("add_child", "main.fleet.timers", "r1")
  answered("remove_child", "main.fleet.lights_r2")
  local key = "fleet.main.fleet.lights"
  T.eq(writes, {
    { [key] = { hosts = { "r2" }, last = { what = "added", instance = "lights_r2" } } },
    { [key] = { hosts = { "r2", "r1" }, last = { what = "added", instance = "lights_r1" } } },
    { ["fleet.main.fleet.timers"] = { hosts = { "r1" }, last = { what = "added", instance = "timers_r1" } } },
    { [key] = { hosts = { "r1" }, last = { what = "removed", instance = "lights_r2" } } },
  })
  T.eq(c.config[key].hosts, { "r1" })
end)

return suite:run(...)
