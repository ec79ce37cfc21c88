-- The supervisor's logic (dca.supervisor) on the in-memory cluster (dca.supervisor.memory): the start protocol,
-- local event handling, LIFO aborts, faults, and that events stay with their owner.
local T = require "dca.testing"
local fake = require "dca.supervisor.memory"
local spec_mod = require "dca.supervisor.spec"
local suite = T.suite("supervisor")

local leaf, group, root, set = fake.leaf, fake.group, fake.root, fake.set

-- Behaviours: a Threshold ends DONE after 2 s, a Timer after args[1] s, a Crash aborts at once.
local behave = {
  Threshold = function(n) n:after(2, function() n:done(1.5) end) end,
  Timer = function(n) n:after(n.args[1] or 1, function() n:done("timeout") end) end,
  Fail = function(n) n:after(1, function() n:aborted("sensor fault") end) end,
}

-- The start of `spec` (root options `...`) on cluster `c` fails. --> its reason
local function start_fails(c, spec, ...)
  c:root(spec, ...)
  local ok, err = c:configure()
  T.eq(ok, nil, "the start fails")
  return err
end

-- A cluster (fake.cluster's options; the behaviours above unless given) running `spec`: started and run.
local function running(spec, opts)
  opts = opts or {}
  opts.behave = opts.behave or behave
  local c = fake.cluster(opts)
  c:root(spec)
  assert(c:configure())
  c:start()
  return c
end

-- `text` contains every fragment given.
local function says(text, ...)
  for _, f in ipairs({ ... }) do T.contains(text, f) end
end

-- Once `c` has settled no process is left.
local function nothing_left(c)
  c:settle()
  T.eq(c:alive(), {})
end

local function compliant()
  return root("main", "h1", "hit # (forcedata[lbl1], compliant[lbl1], puma)", {
    leaf("forcedata", "ForceSensor", "h1"), leaf("compliant", "CompliantCtrl", "h1"),
    leaf("puma", "Puma560", "h2"), leaf("hit", "Threshold", "h1", { 2.0 }),
  }, {
    set("forcedata", "lbl1", { { "forcedata", "Out1", "compliant", "In1" }, { "forcedata", "Out1", "hit", "In1" } }),
    set("compliant", "lbl1", { { "compliant", "Out1", "puma", "In1" } }),
  })
end

local function index_of(list, pattern)
  for i, s in ipairs(list) do if s:find(pattern, 1, true) then return i end end
end

suite:case("start_protocol_starts_everything_inactive_then_connects_before_any_run", function()
  local c = fake.cluster{ behave = behave }
  c:root(compliant())
  T.eq(c:configure(), true)
  T.eq(#c:alive(), 4, "four nodes")
  -- connections were made at the source nodes, inactive, with the set id of the group
  local fd = c:node("main.forcedata")
  T.eq(#fd.conns, 2)
  T.eq(fd.conns[1].set, "main:forcedata[lbl1]")
  T.eq(fd.conns[1].to, "main.compliant")
  T.eq(next(fd.active), nil, "nothing active before run")
  for _, cmd in ipairs(c.commands) do T.ok(not cmd:find(" run"), "no run before 'run': " .. cmd) end
  T.eq(c.root_sup.state, "configured")
end)

suite:case("compliant_motion_hit_ends_done_and_aborts_lifo", function()
  local c = running(compliant())
  local out = c:outcome_within(100)
  T.eq(out and out.type, "done")
  T.eq(out.value, 1.5)
  -- activation of the lbl1 sets before the start, at their sources only
  local a = index_of(c.commands, "main.forcedata activate main:forcedata[lbl1]")
  local r = index_of(c.commands, "main.forcedata run")
  T.ok(a and r and a < r, "activate before run")
  -- LIFO: puma, compliant, forcedata
  local sp, sc, sf = index_of(c.commands, "main.puma stop"), index_of(c.commands, "main.compliant stop"),
    index_of(c.commands, "main.forcedata stop")
  T.ok(sp and sc and sf and sp < sc and sc < sf, "stop order puma, compliant, forcedata")
  T.eq(next(c:node("main.forcedata").active), nil, "deactivated after the run")
  T.eq(next(c:node("main.compliant").active), nil, "deactivated after the run")
end)

-- A three-level tree: main -> door(DoorOpenSystem on h2) -> hitg(HitDetector on h3) with external_io aliases.
local function door()
  local hitg = group("hitg", "HitDetector", "h3", "hit # (ft[l], comp[l])", {
    leaf("ft", "ForceTorque", "h3"), leaf("comp", "CompliantCtrl", "h3"), leaf("hit", "Threshold", "h3"),
  }, { set("ft", "l", { { "ft", "Out", "comp", "In" }, { "ft", "Out", "hit", "In" } }) },
  { { alias = "Vel", instance = "comp", port = "Out" } })
  local mc = group("mc", "MotionControl", "h2", "rr , base", {
    leaf("rr", "RedundancyResolution", "h2"), leaf("base", "XR4000Ctrl", "h2"),
  }, { set("rr", "x", { { "rr", "Out", "base", "In" } }) },
  { { alias = "Vel", instance = "rr", port = "In" } })
  local doorg = group("door", "DoorOpenSystem", "h2", "mc , (vs # dist ; hitg)", {
    mc, leaf("vs", "VisualServoing", "h1"), leaf("dist", "Threshold", "h1"), hitg,
  }, { set("hitg", "lbl1", { { "hitg", "Vel", "mc", "Vel" } }) })
  return root("main", "h1", "door", { doorg })
end

suite:case("external_io_aliases_resolve_to_leaf_ports_and_connect_at_the_real_source", function()
  local s = door()
  local d = spec_mod.child(s, "door").spec
  local w = assert(spec_mod.wiring(d))
  T.eq(w[1], { set = "main.door:hitg[lbl1]", src = "main.door.hitg.comp", out = "Out", dst = "main.door.mc.rr", ["in"] = "In" })
  local c = fake.cluster{ behave = behave }
  c:root(s)
  T.eq(c:configure(), true)
  local conns = c:node("main.door.hitg.comp").conns
  T.eq(conns[1], { out = "Out", to = "main.door.mc.rr", ["in"] = "In", set = "main.door:hitg[lbl1]" })
  T.eq(spec_mod.hosts(s), { "h1", "h2", "h3" })
end)

suite:case("a_group_reports_to_its_parent_only_when_its_expression_ends", function()
  local c = running(door())
  c:settle(1.5)
  -- dist (a Threshold) is done at t=2: until then nothing went up from door to main
  for _, m in ipairs(c.trace) do
    T.ok(not (m.from == "main.door" and m.to == "main" and m.kind == "event"), "no event up before the end")
  end
  c:settle(3)
  T.ok(c:node("main.door.hitg.hit").running, "hit group started after dist")
  T.ok(not c:node("main.door.vs").running, "vs aborted by dist")
  c:settle(10)
  T.eq(c:node("main.door.hitg.hit").running, false)
  -- hitg is done; door's expression still runs (mc never ends), so main heard nothing
  T.eq(c.outcome, nil)
  local ups = 0
  for _, m in ipairs(c.trace) do if m.from == "main.door.hitg" and m.to == "main.door" and m.kind == "event" then ups = ups + 1 end end
  T.eq(ups, 1, "one event from hitg to door: its outcome")
end)

suite:case("leaf_events_go_only_to_the_owning_supervisor", function()
  local c = running(door())
  c:settle(10)
  local owner = { ["main.door.hitg.hit"] = "main.door.hitg", ["main.door.hitg.ft"] = "main.door.hitg",
                  ["main.door.dist"] = "main.door", ["main.door.vs"] = "main.door" }
  local seen = 0
  for _, m in ipairs(c.trace) do
    if owner[m.from] and m.kind == "event" then
      seen = seen + 1
      T.eq(m.to, owner[m.from], "event of " .. m.from)
    end
    T.ok(not (m.kind == "event" and (m.type == "done" or m.type == "aborted") and m.to == "main" and m.from ~= "main.door"),
      "main hears only from its own child")
  end
  T.ok(seen >= 2, "leaf events seen")
end)

suite:case("a_leaf_crash_mid_run_aborts_the_group_lifo_and_names_the_leaf", function()
  local c = running(compliant())
  c:settle(1)
  c:kill("main.compliant", "SEGV")
  local out = c:outcome_within(100)
  T.eq(out.type, "aborted")
  T.eq(out.path, "main.compliant")
  T.contains(out.reason, "SIGSEGV")
  local sp, sh, sf = index_of(c.commands, "main.puma stop"), index_of(c.commands, "main.hit stop"),
    index_of(c.commands, "main.forcedata stop")
  T.ok(sp and sh and sf and sp < sf and sf < sh, "LIFO: puma, forcedata, then hit (started first)")
end)

suite:case("a_host_lost_mid_run_is_an_aborted_event_naming_the_host", function()
  local c = running(door())
  c:settle(2.5)
  c:lose_host("h3")
  local out = c:outcome_within(100)
  T.eq(out.type, "aborted")
  T.contains(out.reason, "h3")
  T.eq(out.path, "main.door.hitg")
end)

suite:case("a_part_that_fails_to_start_fails_the_start_by_name_and_nothing_is_left", function()
  local c = fake.cluster{ behave = behave }
  c.fail_spawn["main.door.hitg.ft"] = "no such controller type 'ForceTorque'"
  local err = start_fails(c, door())
  says(err, "main.door.hitg.ft", "ForceTorque")
  c:settle()
  T.eq(c:alive(), {}, "everything already started is stopped")
end)

-- The door tree with `config("key")` arguments in a leaf two groups down (the hit threshold's force).
local function door_with_config(key)
  local s = door()
  local hitg = spec_mod.child(spec_mod.child(s, "door").spec, "hitg").spec
  local hit = spec_mod.child(hitg, "hit")
  hit.args = { { config = key }, 3 }
  hit.params = { { name = "force", type = "number" }, { name = "samples", type = "integer" } }
  return s
end

suite:case("config_parameters_are_read_from_the_repository_at_start", function()
  local c = fake.cluster{ behave = behave, config = { ["door.hit_force"] = 6.5 } }
  c:root(door_with_config("door.hit_force"))
  T.eq(c:configure(), true)
  T.eq(c:node("main.door.hitg.hit").args, { 6.5, 3 }, "the node starts with the repository's value")
end)

suite:case("an_unknown_config_key_fails_the_start_naming_process_parameter_and_key", function()
  local c = fake.cluster{ behave = behave, config = { ["door.hit_force"] = 6.5 } }
  local err = start_fails(c, door_with_config("door.hit_forse"))
  says(err, "main.door.hitg.hit", "parameter 1 'force'", "config key 'door.hit_forse'", "unknown key")
  c:settle()
  T.eq(c:alive(), {}, "everything already started is stopped")
end)

suite:case("a_config_value_that_is_a_table_fails_the_start_a_parameter_is_a_scalar", function()
  local c = fake.cluster{ behave = behave, config = { ["door.hit_force"] = { 1, 2 } } }
  local s = door_with_config("door.hit_force")
  spec_mod.child(spec_mod.child(spec_mod.child(s, "door").spec, "hitg").spec, "hit").params = nil  -- no manifest
  local err = start_fails(c, s)
  T.contains(err, "main.door.hitg.hit")
  T.contains(err, "parameter 1 (config key 'door.hit_force'): the value is a table; a controller parameter is a "
    .. "number, a string or a boolean")
  nothing_left(c)
end)

suite:case("a_config_value_of_the_wrong_type_fails_the_start_naming_the_parameter", function()
  local c = fake.cluster{ behave = behave, config = { ["door.hit_force"] = "strong" } }
  local err = start_fails(c, door_with_config("door.hit_force"))
  says(err, "main.door.hitg.hit",
    "parameter 1 'force' (config key 'door.hit_force'): the value \"strong\" is a string, not a number")
  nothing_left(c)
end)

suite:case("a_failed_start_waits_for_the_spawns_in_flight_and_stops_them_too", function()
  local s = root("main", "h1", "a , b , c", {
    leaf("a", "Timer", "h1", { 1 }), leaf("b", "Timer", "h2", { 1 }), leaf("c", "Timer", "h3", { 1 }) })
  local c = fake.cluster{ behave = behave, timeouts = { spawn = 2 } }
  c.fail_spawn["main.a"] = "no such controller type 'Timer'"
  c.spawn_delay["main.b"] = 1     -- answers after a's failure, within the spawn timeout
  c.spawn_delay["main.c"] = 3     -- answers after the spawn timeout: killed when it arrives
  local err = start_fails(c, s, { timeouts = { spawn = 2 } })
  T.contains(err, "main.a: could not start on host h1: no such controller type 'Timer'")
  c:settle(10)
  T.eq(c:alive(), {}, "b, started after a failed, and c, started after its timeout, are stopped")
  T.ok(c:node("main.b") ~= nil and c:node("main.c") ~= nil, "both did start")
end)

suite:case("a_part_that_does_not_answer_times_out_by_name", function()
  local c = fake.cluster{ behave = behave, timeouts = { spawn = 2 } }
  c.fail_spawn["main.door.mc.base"] = "silent"
  local err = start_fails(c, door(), { timeouts = { spawn = 2 } })
  says(err, "main.door.mc.base", "did not start within")
  nothing_left(c)
end)

suite:case("tidy_up_timer_ends_the_task_and_aborts_the_finders", function()
  local s = root("main", "h1", "Timeout # (FindA : PlaceA , FindB : PlaceB)", {
    leaf("Timeout", "Timer", "h1", { 5 }), leaf("FindA", "Finder", "h1"), leaf("PlaceA", "Placer", "h2"),
    leaf("FindB", "Finder", "h2"), leaf("PlaceB", "Placer", "h2"),
  })
  local c = running(s)
  c:settle(1)
  c:node("main.FindA"):done({ x = 1 })
  c:settle(2)
  T.ok(c:node("main.PlaceA").running, "PlaceA runs with FindA's value")
  local out = c:outcome_within(100)
  T.eq(out, { type = "done", value = "timeout" })
  T.ok(not c:node("main.PlaceA").running and not c:node("main.FindB").running)
end)

suite:case("shutdown_stops_every_process_lifo", function()
  local c = running(door())
  c:settle(1)
  local done = false
  c.root_sup:shutdown(function() done = true end)
  c:settle(nil, function() return done end)
  T.ok(done)
  T.eq(c:alive(), {})
end)

suite:case("a_silent_child_supervisor_is_lost_after_the_silence_naming_its_host_and_its_subtree_ends", function()
  local c = running(door(), { behave = behave, heartbeat = { 1, 3 } })
  c:settle(0.5)
  T.ok(c:freeze("main.door.mc"), "mc's supervisor stops answering (SIGSTOP)")
  local out = c:outcome_within(30)
  T.eq(out and out.type, "aborted")
  T.eq(out.path, "main.door.mc")
  T.contains(out.reason, "supervisor lost on host h2 (no answer for 3s")
  T.ok(c.t >= 3 and c.t < 10, "found within a period or two after the silence: " .. c.t)
  for _, p in ipairs(c:alive()) do T.ok(not p:find("^main%.door%.mc"), "left running: " .. p) end
  local done = false
  c.root_sup:shutdown(function() done = true end)
  c:settle(c.t + 60, function() return done end)
  T.eq(c:alive(), {})
end)

-- Two hardware-facing types: a base drive (command out to the robot, odometry in) and a plain controller.
local device_types = {
  Drive = { inputs = { { name = "Odom", device = "base.pose" }, { name = "Vel" } },
            outputs = { { name = "Cmd", device = "base.cmd_vel" } } },
  Planner = { inputs = {}, outputs = { { name = "Vel" } } },
}
local function robot()
  return root("main", "h1", "plan , drive", { leaf("plan", "Planner", "h1"), leaf("drive", "Drive", "h2") },
    { set("plan", "run", { { "plan", "Vel", "drive", "Vel" } }) })
end

suite:case("device_ports_are_wired_to_the_world_at_connect_time_and_stay_active", function()
  local c = fake.cluster{ behave = behave, types = device_types, world = true }
  c:root(robot())
  T.eq(c:configure(), true)
  local world, drive = c:node("world"), c:node("main.drive")
  -- input: world -> leaf, made and activated at the world; output: leaf -> world, at the leaf
  T.eq(world.conns, { { out = "base.pose", to = "main.drive", ["in"] = "Odom", set = "main.drive:device", queue = 1 } })
  T.eq(world.active, { ["main.drive:device"] = true })
  T.eq(drive.conns, { { out = "Cmd", to = "world", ["in"] = "base.cmd_vel", set = "main.drive:device", queue = 1 } })
  T.eq(drive.active, { ["main.drive:device"] = true }, "active before any run, for good")
  -- samples flow both ways through the device set; the planner's own set is still inactive
  world:write("base.pose", { 1, 2, 3 })
  drive:write("Cmd", { 0.1, 0, 0 })
  c:settle(c.t)
  T.eq(drive.ports.Odom, { 1, 2, 3 })
  T.eq(world.ports["base.cmd_vel"], { 0.1, 0, 0 })
  -- a run and its end (LIFO stops, deactivations of the labelled sets) leave the device set active
  c:start()
  c:settle(1)
  c:node("main.plan"):done(1) c:node("main.drive"):done(2)
  T.eq(c:outcome_within(10), { type = "done", value = { 1, 2, n = 2 } })
  T.eq(drive.active["main.drive:device"], true)
  T.ok(not c:node("main.plan").active["main:plan[run]"], "the labelled set was deactivated")
  T.eq(c:alive(), { "main.plan", "main.drive" }, "the world is not one of the tree's processes")
end)

-- A type for any number of joints, up to its slots (joint_control's): a slot past the leaf's joints is not wired.
suite:case("only_the_slots_a_leaf_s_joints_name_are_wired_to_the_world", function()
  local types = { Arm = { inputs = { { name = "Q1", device = "joint.{joints[1]}.position" },
                                     { name = "Q2", device = "joint.{joints[2]}.position" } },
                          outputs = { { name = "Cmd1", device = "joint.{joints[1]}.position_command" },
                                      { name = "Cmd2", device = "joint.{joints[2]}.position_command" } },
                          params = { { name = "joints", type = "string", required = true } } } }
  local c = fake.cluster{ behave = behave, types = types, world = true }
  c:root(root("main", "h1", "arm", { leaf("arm", "Arm", "h1", { "elbow" }) }, {}))
  T.eq(c:configure(), true)
  T.eq(c:node("world").conns,
       { { out = "joint.elbow.position", to = "main.arm", ["in"] = "Q1", set = "main.arm:device", queue = 1 } })
  T.eq(c:node("main.arm").conns,
       { { out = "Cmd1", to = "world", ["in"] = "joint.elbow.position_command", set = "main.arm:device", queue = 1 } })
end)

suite:case("a_missing_world_fails_the_start_naming_the_leaf_and_its_device_ports", function()
  local c = fake.cluster{ behave = behave, types = device_types }
  local err = start_fails(c, robot())
  says(err, "no world for the device ports of main.drive (Drive: Odom <- base.pose, Cmd -> base.cmd_vel)", "--sim")
  T.eq(c:alive(), {}, "nothing left running")
end)

suite:case("an_expression_naming_an_unknown_process_fails_before_anything_starts", function()
  local c = fake.cluster{ behave = behave }
  local err = start_fails(c, root("main", "h1", "a ; nosuch", { leaf("a", "Timer", "h1") }))
  T.contains(err, "unknown process 'nosuch'")
  T.eq(c:alive(), {})
end)

suite:case("reloading_the_module_keeps_running_supervisors_and_their_state", function()
  local c = fake.cluster{ behave = behave }
  local sup = c:root(compliant())
  assert(c:configure())
  local before = getmetatable(sup)
  package.loaded["dca.supervisor"] = require("dca.supervisor") -- same table, reloaded code
  local path = package.searchpath("dca.supervisor", package.path)
  local fresh = assert(loadfile(path))("dca.supervisor")
  T.ok(getmetatable(sup) == before and fresh.Sup == before, "the method table is updated in place")
  c:start()
  T.eq(c:outcome_within(100).type, "done")
end)

suite:case("a_groups_init_value_binds_every_leaf_it_starts", function()
  local seen = {}
  local b = { Rec = function(n, init) seen[n.path] = init n:after(1, function() n:done(init) end) end,
              Finder = function(n) n:after(1, function() n:done({ x = 3 }) end) end }
  local sub = group("place", "Place", "h2", "grip ; move", { leaf("grip", "Rec", "h2"), leaf("move", "Rec", "h2") })
  local c = running(root("main", "h1", "find : place", { leaf("find", "Finder", "h1"), sub }), { behave = b })
  local out = c:outcome_within(100)
  T.eq(out, { type = "done", value = { x = 3 } })
  T.eq(seen["main.place.grip"], { x = 3 })
  T.eq(seen["main.place.move"], { x = 3 })
end)

suite:case("an_abort_from_the_parent_is_acknowledged_after_every_stop_below", function()
  local c = running(door())
  c:settle(2.5)
  local acked = false
  local door_sup = c.sups["main.door"]
  door_sup:abort(function() acked = true end)
  T.eq(acked, false, "not before the stops are acknowledged")
  c:settle(nil, function() return acked end)
  T.ok(acked)
  for _, p in ipairs({ "main.door.mc.rr", "main.door.mc.base", "main.door.hitg.ft", "main.door.hitg.hit" }) do
    T.eq(c:node(p).running, false, p .. " stopped")
  end
  T.eq(c.outcome, nil, "an abort from the parent reports nothing up")
end)

suite:case("a_recurrent_group_restarts_its_sub_group_each_iteration", function()
  local runs = 0
  local b = { Step = function(n) runs = runs + 1 n:after(1, function() n:done(runs) end) end,
              Timer = behave.Timer }
  local sub = group("body", "Body", "h2", "step", { leaf("step", "Step", "h2") })
  local c = fake.cluster{ behave = b }
  c:root(root("main", "h1", "stop # (tick :; body)", {
    leaf("stop", "Timer", "h1", { 10.5 }), leaf("tick", "Step", "h1"), sub }))
  assert(c:configure())
  c:start()
  local out = c:outcome_within(100)
  T.eq(out, { type = "done", value = "timeout" })
  T.ok(runs >= 10, "iterations: " .. runs)
  T.eq(c:node("main.body.step").running, false)
end)

suite:case("preemption_latency_is_recorded_where_the_event_lands_and_read_through_the_tree", function()
  local c = running(door())
  c:settle(2.5) -- dist (Threshold, 2 s) preempted vs in main.door; hitg started
  local r
  c.root_sup:handle({ type = "stats", path = "main.door" }, function(m) r = m end)
  c:settle(nil, function() return r ~= nil end)
  T.eq(r.type, "ok")
  T.eq(r.path, "main.door")
  T.eq(r.stats.preempt_n, 1)
  T.eq(#r.stats.preempt, 1)
  T.ok(r.stats.leaf_events >= 1)
end)

-- Restarts `path` with `sup` (a supervisor of the cluster `c`) and settles until it answered. --> ok, err
local function restart(c, sup, path)
  local r
  sup:restart(path, function(ok, err) r = { ok, err } end)
  c:settle(nil, function() return r ~= nil end)
  return r[1], r[2]
end

-- The pid of the live process at `path`.
local function pid(c, path)
  for _, p in ipairs(c.procs) do if p.path == path and p.alive then return p.pid end end
end

suite:case("a_leaf_restarted_by_its_own_group_is_wired_again_by_the_groups_above", function()
  -- main.door.mc.rr's input comes from main.door.hitg.comp: a connection of main.door, not of main.door.mc
  local c = running(door())
  c:settle(3)
  c.sups["main.door"]:switch("main.door.hitg", "lbl1", "activate", function() end)
  local connects = function()
    local n = 0
    for _, cmd in ipairs(c.commands) do
      if cmd == "main.door.hitg.comp connect main.door:hitg[lbl1]" then n = n + 1 end
    end
    return n
  end
  T.eq(connects(), 1)
  local old, base = pid(c, "main.door.mc.rr"), pid(c, "main.door.mc.base")
  T.eq(restart(c, c.sups["main.door.mc"], "main.door.mc.rr"), true)
  c:settle(c.t)
  T.ok(pid(c, "main.door.mc.rr") ~= old, "a new process")
  T.eq(pid(c, "main.door.mc.base"), base, "the others never stopped")
  T.eq(c:node("main.door.mc.rr").running, true, "running again")
  T.eq(connects(), 2, "main.door made its connection to the restarted leaf again (the `restarted` event)")
  T.eq(#c:node("main.door.hitg.comp").conns, 1, "the writer's connection made again is the same one")
  c:node("main.door.hitg.comp"):write("Out", 5)
  c:settle(c.t)
  T.eq(c:node("main.door.mc.rr").ports.In, 5, "the new process hears the writer in another group")
  T.eq(c.outcome, nil, "the algebra saw nothing")
  local lines = table.concat(c.lines, "\n")
  T.ok(not lines:find("main.door.mc.rr: exited", 1, true), "the old process's exit is no crash")
end)

-- A restart answers once the new process has answered its Init and Run: on simulated time a restart by hand while
-- time is held is then done before time moves on, so the tick after it finds the new process's timers (it was:
-- the answer came first, the next advance reached the node before its `run`, and the drive wrote nothing until
-- the idle tick a second later; scenario door_drive_restart, 1 run in 5 under load).
suite:case("a_restart_answers_once_the_new_process_has_answered_its_run", function()
  local c = running(compliant())
  c:settle(1)
  local from, at = #c.trace, nil
  c.root_sup:restart("main.compliant", function(ok) if ok then at = #c.trace end end)
  c:settle(nil, function() return at ~= nil end)
  T.ok(at, "restarted")
  local asked, answered, ran = 0, 0, false
  for i = from + 1, at do
    local m = c.trace[i]
    if m.to == "main.compliant" and m.kind == "request" then
      asked = asked + 1
      ran = ran or m.type == "run"
    end
    if m.from == "main.compliant" and m.kind == "reply" then answered = answered + 1 end
  end
  T.ok(ran, "the new process was asked to run")
  T.eq(answered, asked, "every request to the new process (its run included) was answered before the restart")
  -- counted as a policy's restart is: the tree says so (the monitor's row takes its count from it)
  T.eq(c.root_sup.children.compliant.restarts, 1)
end)

suite:case("a_restart_whose_spawn_fails_ends_the_leaf_aborted_with_the_reason", function()
  local c = running(compliant())
  c:settle(1)
  c.fail_spawn["main.compliant"] = "no such controller type 'CompliantCtrl'"
  local ok, err = restart(c, c.root_sup, "main.compliant")
  T.eq(ok, nil)
  says(err, "main.compliant: could not start on host h1", "no such controller type")
  local out = c:outcome_within(100)
  T.eq(out.type, "aborted")
  T.eq(out.path, "main.compliant")
  says(out.reason, "could not start", "CompliantCtrl")
end)

suite:case("restart_refuses_an_unknown_path_and_a_leaf_whose_process_is_gone", function()
  local c = running(compliant())
  c:settle(1)
  local _, err = restart(c, c.root_sup, "main.nobody")
  says(err, "no process 'main.nobody' under main")
  c:kill("main.puma", "SEGV")
  c:settle(c.t)
  _, err = restart(c, c.root_sup, "main.puma")
  says(err, "main.puma is not running (killed by SIGSEGV")
end)

suite:case("a_restarted_leaf_gets_its_device_ports_and_its_active_sets_again", function()
  local c = fake.cluster{ behave = behave, types = device_types, world = true }
  c:root(robot())
  assert(c:configure())
  c:start()
  c.root_sup:switch("main.plan", "run", "activate", function() end)
  c:settle(1)
  T.eq(restart(c, c.root_sup, "main.plan"), true)
  T.eq(restart(c, c.root_sup, "main.drive"), true)
  local drive, plan, world = c:node("main.drive"), c:node("main.plan"), c:node("world")
  T.eq(drive.active, { ["main.drive:device"] = true }, "the new drive's device set, active")
  T.eq(plan.active, { ["main:plan[run]"] = true }, "the new planner's set, active as before")
  T.eq(#world.conns, 1, "the world's connection to the drive made again is the same one")
  world:write("base.pose", { 4, 5, 6 })
  plan:write("Vel", { 1 })
  drive:write("Cmd", { 0.2, 0, 0 })
  c:settle(c.t)
  T.eq(drive.ports.Odom, { 4, 5, 6 })
  T.eq(drive.ports.Vel, { 1 })
  T.eq(world.ports["base.cmd_vel"], { 0.2, 0, 0 })
  T.eq(drive.running and plan.running, true, "both run again")
end)

suite:case("a_restart_under_an_abort_or_a_shutdown_starts_nothing_more", function()
  local c = running(compliant())
  c:settle(1)
  local r
  c.root_sup:restart("main.compliant", function(ok, err) r = { ok, err } end)
  c.root_sup:abort()
  c:settle(nil, function() return r ~= nil end)
  c:settle(c.t)
  T.eq(c:node("main.compliant").running, false, "aborted by its group meanwhile: not run again")
  r = nil
  c.root_sup:restart("main.forcedata", function(ok, err) r = { ok, err } end)
  local down = false
  c.root_sup:shutdown(function() down = true end)
  c:settle(c.t + 60, function() return down and r ~= nil end)
  c:settle(c.t)
  T.eq(c:alive(), {}, "nothing started after the shutdown")
end)

suite:case("breaks_towards_a_leaf_being_restarted_are_logged_not_said", function()
  local c = running(compliant())
  c:settle(1)
  local r
  c.root_sup:restart("main.compliant", function(ok) r = ok end)
  local broken = { type = "broken", port = "Out1", peer = "main.compliant.In1", reason = "closed by peer" }
  c.root_sup:child_message("forcedata", broken)
  c:settle(nil, function() return r ~= nil end)
  c.root_sup:child_message("forcedata", broken)
  local said = table.concat(c.lines, "\n")
  T.eq(select(2, said:gsub("main.forcedata: broken", "")), 1, "said once, after the restart: " .. said)
  T.contains(table.concat(c.root_sup:recent(50), "\n"), "while main.compliant restarts")
end)

-- The compliant system's types with typed ports (scalars), for the check of a restarted leaf's new ports.
local function scalars(ins, outs)
  local t = { inputs = {}, outputs = {} }
  for _, n in ipairs(ins) do t.inputs[#t.inputs + 1] = { name = n, type = "scalar", size = 1 } end
  for _, n in ipairs(outs) do t.outputs[#t.outputs + 1] = { name = n, type = "scalar", size = 1 } end
  return t
end
local compliant_types = {
  ForceSensor = scalars({}, { "Out1" }), CompliantCtrl = scalars({ "In1" }, { "Out1" }),
  Puma560 = scalars({ "In1" }, {}), Threshold = scalars({ "In1" }, {}),
}

-- Restarts main.compliant whose new code has the ports `new` (memory's c.code): refused with a reason that
-- contains `...`; nothing connected to the new process; the leaf ended ABORTED with the reason.
local function refused_restart(new, ...)
  local c = running(compliant(), { types = compliant_types })
  c:settle(1)
  local from = #c.commands
  c.code["main.compliant"] = new
  local ok, err = restart(c, c.root_sup, "main.compliant")
  T.eq(ok, nil)
  says(err, "restart of main.compliant refused: ", ...)
  for i = from + 1, #c.commands do
    T.ok(not c.commands[i]:find("connect", 1, true), "nothing wired after the restart: " .. c.commands[i])
  end
  T.ok(not c:node("main.compliant").p.alive, "the new process is ended")
  local out = c:outcome_within(100)
  T.eq(out.type, "aborted")
  T.eq(out.path, "main.compliant")
  says(out.reason, "restart of main.compliant refused: ")
  T.contains(table.concat(c.lines, "\n"), "main.compliant: restart failed: restart of main.compliant refused: ")
end

suite:case("a_restart_whose_new_code_lacks_a_connected_port_is_refused_naming_it_and_never_wired", function()
  refused_restart(scalars({ "In1" }, { "Force" }), "its new code has no output 'Out1' (outputs are: Force), "
    .. "which connection main.compliant.Out1 -> main.puma.In1 (set main:compliant[lbl1]) uses")
  refused_restart(scalars({}, { "Out1" }), "its new code has no input 'In1' (inputs are: none), "
    .. "which connection main.forcedata.Out1 -> main.compliant.In1 (set main:forcedata[lbl1]) uses")
end)

suite:case("a_restart_whose_new_code_retyped_a_connected_port_is_refused_naming_both_ends", function()
  local new = scalars({ "In1" }, {})
  new.outputs[1] = { name = "Out1", type = "vector", size = 3 }
  refused_restart(new, "its new code's output 'Out1' is a vector[3], which does not fit connection "
    .. "main.compliant.Out1 -> main.puma.In1 (set main:compliant[lbl1]): main.puma.In1 is a scalar")
end)

-- main.door.mc.rr's input In is the alias Vel of main.door.mc, which main.door connects: its group refuses a
-- restart whose new code lacks it (the group above is not asked: the alias is the use it knows).
suite:case("a_restart_whose_new_code_lacks_a_port_an_external_io_alias_names_is_refused", function()
  local c = running(door())
  c:settle(3)
  c.code["main.door.mc.rr"] = scalars({ "Velocity" }, { "Out" })
  local ok, err = restart(c, c.sups["main.door.mc"], "main.door.mc.rr")
  T.eq(ok, nil)
  T.eq(err, "restart of main.door.mc.rr refused: its new code has no port 'In' (inputs are: Velocity; outputs are: "
    .. "Out), which external_io Vel of main.door.mc uses")
end)

suite:case("a_restart_whose_new_code_keeps_the_connected_ports_goes_on", function()
  local c = running(compliant(), { types = compliant_types })
  c:settle(1)
  c.code["main.compliant"] = scalars({ "In1", "Gain" }, { "Out1", "Debug" })  -- ports added: nothing breaks
  T.eq(restart(c, c.root_sup, "main.compliant"), true)
  c:settle(c.t)
  T.eq(c.root_sup.children.compliant.state, "running")
end)

suite:case("an_unknown_request_is_refused_naming_the_requests_there_are", function()
  local c = fake.cluster{ behave = behave }
  local sup = c:root(compliant())
  local r
  sup:handle({ type = "frobnicate" }, function(m) r = m end)
  T.eq(r.type, "error")
  T.contains(r.reason, "unknown request 'frobnicate' for supervisor main (requests: abort, add_child, clock, complete, config_set, configure,")
  sup:handle({ type = "ping" }, function(m) r = m end)
  T.eq(r, { type = "ok", path = "main", state = "new" })
end)

-- The emergency stop (docs/safety.md): the root's event is kept and said with its source, and reaches every group
-- below; a console's press with no robot to reach, or a release that does not name it, is refused.
suite:case("an_emergency_stop_reaches_every_group_below_the_root_with_its_source", function()
  local c = running(door())
  local requests = require "dca.supervisor.requests"
  requests.estop_event(c.root_sup, { latched = true, t = 1.5, source = "SIGUSR1" }, true)
  c:settle()
  for _, path in ipairs({ "main", "main.door", "main.door.mc", "main.door.hitg" }) do
    T.eq(c.sups[path].estop, { latched = true, t = 1.5, source = "SIGUSR1" }, path)
  end
  T.eq(index_of(c.lines, "main: emergency stop pressed by SIGUSR1 at 1.500 s") ~= nil, true, "said by the root")
  T.eq(index_of(c.sups["main.door"]:recent(5), "main.door: emergency stop pressed by SIGUSR1") ~= nil, true,
    "in the group's log")
  local tree
  c.sups["main.door"]:tree(function(t) tree = t end)
  c:settle()
  T.contains(require("dca.supervisor.console").render_tree(tree, {})[1], "[EMERGENCY STOP by SIGUSR1 at 1.500 s]")
  local r
  c.root_sup:handle({ type = "estop", source = "REPL" }, function(m) r = m end)
  c:settle()
  T.eq(r.type, "error")
  T.contains(r.reason, "no process is registered as `world`")
  c.root_sup:handle({ type = "release", what = "brakes" }, function(m) r = m end)
  T.eq(r, { type = "error", reason = 'release: name what to release: release("estop")' })
end)

-- The values in the run's lines and trace are shown the same in every run: a `,` list item by item in text order,
-- whatever order its items were set in (their completion order) and with its holes as nil; other tables by key.
suite:case("values_are_shown_in_text_order_whatever_the_order_their_items_came_in", function()
  local show = require("dca.supervisor").show
  local early, late = { n = 4 }, { n = 4 }
  for _, i in ipairs({ 4, 2, 1 }) do early[i] = i * 1.5 end
  for _, i in ipairs({ 1, 2, 4 }) do late[i] = i * 1.5 end
  T.eq(show(early), "{1.5, 3.0, nil, 6.0}")
  T.eq(show(late), show(early))
  T.eq(show({ n = 10, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10 }), "{1, 2, 3, 4, 5, 6, 7, 8, ...}")
  T.eq(show({ z = 1, a = "x", [2] = true, [1] = false }), '{false, true, a="x", z=1}')
  T.eq(show({ n = 2, { n = 1, "in" }, "out" }), '{{"in"}, "out"}')
end)

return suite:run(...)
