-- At most one writer per actuator (dca.verify.writers): systems written to have two concurrent writers on a
-- device command input or an `exclusive` input (in one ',', across groups, through a connection-set switch,
-- with a one_for_all policy) each give the finding with a trace that reaches a state where both write, and it
-- replays; the same systems written correctly, the door system and the UR10 example give none. Dead command
-- paths and actuators that two groups claim are reported; `exclusive` names an input, at file:line:col.
local T = require "dca.testing"
local load = require "dca.load"
local verify = require "dca.verify"
local report = require "dca.verify.report"
local scenario = require "dca.verify.scenario"
local suite = T.suite("writers")

local here = T.here()
local golden = here .. "/golden/"
local function abs(p) return (p:sub(1, 1) == "/") and p or (os.getenv("PWD") .. "/" .. p) end

-- The verification of a file's text: the result, and its report.
local function verified(text, name)
  local ast, tree = load.text(text, name or "w.dca", {})
  T.ok(ast, tree)
  local result, errs = verify.system(tree, { ast = ast })
  T.ok(result, errs and T.show(errs))
  return result, (report.text(result, { file = name or "w.dca" }))
end

-- Every two-writer finding of a result: { { input, a, b, r } }.
local function two_writers(result)
  local out = {}
  for _, r in ipairs(result.groups) do
    for _, w in ipairs(r.writers) do out[#out + 1] = { input = w.input, a = w.a, b = w.b, r = r, w = w } end
  end
  return out
end

-- The trace of finding w (at group r) replayed through each group's own expression ends with every path that
-- must run for both writers to write running.
local function check_trace(r, w)
  local algebra = require "dca.algebra"
  local running = {}
  local function replay(g, path, trace)
    local run = algebra.new(g.node.process.actions.expr, {})
    run:start()
    for _, s in ipairs(trace) do if s.ev.kind ~= "stuck" then run:event(s.name, s.ev.kind, s.ev.value) end end
    T.eq(run:status(), "running", path .. " still runs")
    for _, name in ipairs(g.node.process.actions.expr.names) do
      if run:is_running(name) then running[path .. "." .. name] = true end
    end
  end
  replay(r, r.path, w.trace)
  for _, inner in ipairs(w.inner) do replay(inner.r, inner.path, inner.trace) end
  for _, path in ipairs(w.running) do T.ok(running[path], path .. " runs at the end of the trace") end
end

local function finds(file, input, a, b)
  local result = verified(T.read(golden .. file), file)
  local found = two_writers(result)
  T.eq(#found, 1, file)
  T.eq({ found[1].input, found[1].a, found[1].b }, { input, a, b })
  check_trace(found[1].r, found[1].w)
  return result
end

suite:case("two_writers_in_one_par_are_found_with_a_trace", function()
  finds("writers_par.dca", "world.gripper.cmd", "main.open.Cmd", "main.close.Cmd")
  -- written as a sequence: none
  local text = T.read(golden .. "writers_par.dca"):gsub("stop # %(open, close%)", "stop # (open ; close)")
  local result = verified(text)
  T.eq(#two_writers(result), 0)
end)

suite:case("two_writers_across_groups_are_found_with_the_traces_inside", function()
  local result = finds("writers_groups.dca", "world.base.cmd_vel", "main.left.drive.Cmd", "main.right.drive.Cmd")
  local w = two_writers(result)[1].w
  T.eq({ w.inner[1].path, w.inner[2].path }, { "main.left", "main.right" })
  -- main runs the groups one after the other: none, but the actuator is claimed by two groups
  local text = T.read(golden .. "writers_groups.dca"):gsub("stop # %(left, right%)", "left ; right")
  local r2, out = verified(text)
  T.eq(#two_writers(r2), 0)
  T.contains(out, "FINDING world.base.cmd_vel is claimed by two groups: main.left (main.left.drive.Cmd) and " ..
    "main.right (main.right.drive.Cmd)")
end)

suite:case("two_writers_through_a_connection_set_switch_on_an_exclusive_input", function()
  finds("writers_label.dca", "main.drive.Vel", "main.fast.Out", "main.slow.Out")
  -- the switch that ends the first set before the second starts: none
  local text = T.read(golden .. "writers_label.dca")
    :gsub("%(drive, fast%[lbl1%], %(wait ; slow%[lbl1%]%)%)", "(drive, ((fast[lbl1] # wait) ; slow[lbl1]))")
  local result, out = verified(text)
  T.eq(#two_writers(result), 0, out)
  T.contains(out, "holds     exclusive drive.Vel")
  T.contains(select(2, verified(T.read(golden .. "writers_label.dca"))), "VIOLATED  exclusive drive.Vel\n" ..
    "    main.fast.Out and main.slow.Out can write it in the same state")
  -- the drive's own labels switching the source: none either
  local own = T.read(golden .. "writers_label.dca")
    :gsub("internal_connections%(fast, lbl1%)", "internal_connections(drive, lbl1)")
    :gsub("internal_connections%(slow, lbl1%)", "internal_connections(drive, lbl2)")
    :gsub("%(drive, fast%[lbl1%], %(wait ; slow%[lbl1%]%)%)", "(fast, slow, ((drive[lbl1] # wait) ; drive[lbl2]))")
  local r3, out3 = verified(own)
  T.eq(#two_writers(r3), 0, out3)
  T.ok(not out3:find("FINDING", 1, true), out3)
end)

suite:case("two_writers_with_a_one_for_all_restart_are_found", function()
  -- a restart starts Arm at its first step: a state of its exploration, so the finding is there, policy or not
  local result = finds("writers_restart.dca", "world.gripper.cmd", "main.arm.open.Cmd", "main.close.Cmd")
  local text = T.read(golden .. "writers_restart.dca"):gsub("supervision {[^}]*}", "")
  local plain = verified(text)
  T.eq(#two_writers(plain), #two_writers(result))
end)

suite:case("the_door_system_and_the_ur10_example_have_one_writer_per_actuator", function()
  local _, out = verified(T.read(T.src .. "/scripts/systems/door_open.dca"), "door_open.dca")
  T.contains(out, "0 findings")
  local dca = os.getenv("DCA_EXE")
  local text = T.dca("check --verify " .. T.src .. "/examples/ur10/pick_and_place.dca --sim " .. T.src ..
                     "/worlds/ur10/ur10.urdf", 0, "0 findings, 0 violated properties")
  T.ok(dca and text)
end)

-- (c never runs: the laser never ends; a dead button is no dead actuator either)
suite:case("emergency_stop_buttons_are_no_writers_of_an_actuator", function()
  local _, out = verified([[
process main() {
  instantiated_processes { a instof EStopButton("arm", 1.0); b instof EStopButton("arm", 2.0);
                           c instof EStopButton("arm", 3.0); laser instof LaserSensor("arm"); }
  internal_event_actions { (a , b) ; (laser ; c) }
}
]])
  T.ok(not out:find("two writers", 1, true) and not out:find("dead actuator", 1, true), out)
end)

suite:case("dead_command_paths_and_dead_actuators_are_reported", function()
  local _, out = verified(T.read(golden .. "writers_dead.dca"), "writers_dead.dca")
  T.contains(out, "FINDING dead command path: main.src.Out -> main.drive.Vel (set main:src[lbl1]) never reaches " ..
    "world.base.cmd_vel")
  T.contains(out, "FINDING dead actuator: main.grip never runs, so main.grip.Cmd never reaches world.gripper.cmd")
end)

suite:case("a_chain_of_connections_that_never_reaches_its_drive_is_a_dead_command_path", function()
  -- src feeds gain only before the drive runs; gain feeds the drive while it runs: the last hop lives, the
  -- chain src -> gain -> drive is dead (and reported once, not again for chains through it)
  local _, out = verified([[
process main() {
  instantiated_processes {
    src   instof Constant("h", 0.1, 1, 0, 0);
    gain  instof Gain("h", 2);
    drive instof XR4000Ctrl("h");
    warm  instof Timer("h", 1);
    stop  instof Timer("h", 5);
  }
  internal_connections(src, lbl1)  { src, Out -> gain, In; }
  internal_connections(gain, lbl1) { gain, Out -> drive, Vel; }
  internal_event_actions { (src[lbl1] # warm) ; (stop # (gain[lbl1], drive)) }
}
]], "chain.dca")
  T.contains(out, "FINDING dead command path: main.src.Out -> main.gain.In; main.gain.Out -> main.drive.Vel " ..
    "(set main:src[lbl1]) never reaches world.base.cmd_vel: never all active together while its drive runs")
  local _, n = out:gsub("dead command path", "")
  T.eq(n, 1, out)
end)

suite:case("exclusive_names_an_input_of_an_instance_at_file_line_col", function()
  local text = T.read(golden .. "writers_label.dca"):gsub("exclusive drive%.Vel", "exclusive drive.Cmd")
  local ast, tree = load.text(text, "w.dca", {})
  T.ok(ast, tree)
  local result, errs = verify.system(tree, { ast = ast })
  T.eq(result, nil)
  T.eq({ errs[1].line, errs[1].col }, { 15, 28 })
  T.contains(errs[1].msg, "'drive' has no input 'Cmd'")
  local bad = T.read(golden .. "writers_label.dca"):gsub("exclusive drive%.Vel", "exclusive nobody.Vel")
  local a2, t2 = load.text(bad, "w.dca", {})
  T.ok(not a2 or not t2 or not verify.system(t2, { ast = a2 }), "an unknown instance is an error")
end)

suite:case("the_two_writer_findings_replay_as_scenarios", function()
  for _, f in ipairs({ "writers_par.dca", "writers_groups.dca" }) do
    local file = abs(golden .. f)
    local ast, tree = load.file(file)
    T.ok(ast, tree)
    local result = assert(verify.system(tree, { ast = ast }))
    local all = scenario.all(result)
    local text, what = scenario.text(result, file, "main", #all)
    local path = T.tmpfile(text, ".lua")
    T.dca("scenario " .. path, 0, "the violation: " .. what, "0 failed")
    os.remove(path)
  end
end)

return suite:run(...)
