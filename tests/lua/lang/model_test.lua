-- dca.lang.model: the instantiated tree the supervisor uses (paths, kinds, hosts, bound arguments).
local T = require "dca.testing"
local parser = require "dca.lang.parser"
local model = require "dca.lang.model"
local suite = T.suite("model")

local function load(name)
  return assert(parser.parse(T.read(T.src .. "/scripts/systems/" .. name .. ".dca"), name .. ".dca"))
end

suite:case("door_tree_paths_kinds_hosts_args", function()
  local tree = assert(model.build(load("door_open")))
  T.eq({ tree.path, tree.kind, tree.type, tree.host }, { "main", "group", "main", nil })
  local sys = tree.children.dooropensyst
  T.eq({ sys.path, sys.kind, sys.type, sys.host }, { "main.dooropensyst", "group", "DoorOpenSystem", "manipulation" })
  T.eq(sys.bindings, { host1 = "vision", host2 = "platform", host3 = "manipulation" })
  local hit = model.find(tree, "main.dooropensyst.hit")
  T.eq({ hit.kind, hit.type, hit.host }, { "group", "HitDetector", "manipulation" })
  local force = model.find(tree, "main.dooropensyst.hit.force")
  T.eq({ force.kind, force.type, force.host, force.args, force.params },
       { "leaf", "ForceTorque", "manipulation", { "manipulation" }, {} })
  T.ok(force.parent == hit)
  local grip = model.find(tree, "main.dooropensyst.opengrip")
  T.eq({ grip.host, grip.args, grip.params }, { "manipulation", { "manipulation", "open" }, { "open" } })
  local xr = model.find(tree, "main.dooropensyst.motionctrl.xr4000")
  T.eq(xr.host, "platform")
  T.eq(model.find(tree, "main.dooropensyst.motionctrl").host, "manipulation")
  T.eq(model.find(tree, "main.nope"), nil)
  T.eq(model.find(tree, "other.dooropensyst"), nil)
  -- children in declaration order, the expression reachable from the group
  T.eq(sys.children[1].name, "camera")
  T.ok(sys.process.actions.expr, "expression")
  local s = model.summary(tree)
  T.eq({ s.groups, s.instances, s.leaves, s.connections, s.hosts }, { 6, 27, 22, 20, { "manipulation", "platform", "vision" } })
end)

suite:case("group_without_host_runs_on_the_parent_host", function()
  local ast = assert(parser.parse([[
process Inner(h) { instantiated_processes { t instof Timer(h, 1); } internal_event_actions { t } }
process Outer(a, b) { host { a } instantiated_processes { i instof Inner(b); } internal_event_actions { i } }
process main() { instantiated_processes { o instof Outer("x", "y"); } internal_event_actions { o } }
]], "h.dca"))
  local tree = assert(model.build(ast, { host = "local" }))
  T.eq(tree.host, "local")
  T.eq(model.find(tree, "main.o").host, "x")
  T.eq(model.find(tree, "main.o.i").host, "x")
  T.eq(model.find(tree, "main.o.i.t").host, "y")
  T.eq(model.find(tree, "main.o.i.t").params, { 1 })
end)

suite:case("root_arguments_and_chosen_root", function()
  local ast = assert(parser.parse([[
process Pair(h1, h2) { host { h1 } instantiated_processes { a instof Timer(h1, 1); b instof Timer(h2, 2); }
                       internal_event_actions { a , b } }
]], "pair.dca"))
  local tree = assert(model.build(ast, { root = "Pair", args = { "c1", "c2" } }))
  T.eq({ tree.path, tree.host }, { "Pair", "c1" })
  T.eq(model.find(tree, "Pair.b").host, "c2")
  local none, errs = model.build(ast, { root = "Pair" })
  T.eq(none, nil)
  T.eq(errs[1].msg, "the root process 'Pair' takes 2 arguments, 0 given")
  local bad
  bad, errs = model.build(ast, { root = "Pair", args = { 1, "c2" } })
  T.eq(bad, nil)
  T.eq(errs[1].msg, "the host of Pair is 1 (its parameter 'h1'), not a host name")
end)

suite:case("check_errors_refuse_the_tree", function()
  local ast = assert(parser.parse([[process main() { instantiated_processes { a instof T(); } internal_event_actions { a } }]],
                                  "bad.dca"))
  local tree, errs = model.build(ast)
  T.eq(tree, nil)
  T.eq(#errs, 1)
  T.contains(errs[1].msg, "has no host")
end)

suite:case("walk_visits_parents_first", function()
  local tree = assert(model.build(load("compliant_motion")))
  local seen = {}
  model.walk(tree, function(n, depth) seen[#seen + 1] = depth .. ":" .. n.path end)
  T.eq(seen, { "0:main", "1:main.motion", "2:main.motion.forcedata", "2:main.motion.compliant",
               "2:main.motion.joints", "2:main.motion.redundancy", "2:main.motion.puma", "2:main.motion.hit" })
end)

suite:case("connections_resolve_through_exports", function()
  local tree = assert(model.build(load("door_open")))
  local conns = assert(model.connections(tree))
  local seen = {}
  for _, c in ipairs(conns) do
    seen[#seen + 1] = string.format("%s: %s.%s -> %s.%s", c.set, c.from.path, c.out, c.to.path, c["in"])
  end
  -- visualserv's velocity reaches the redundancy resolution inside motionctrl (MotionControl's In)
  T.ok(seen[2]:find("main.dooropensyst.visualserv.Vel -> main.dooropensyst.motionctrl.redundancy.In", 1, true), seen[2])
  local found
  for _, line in ipairs(seen) do
    if line == "main.dooropensyst:dooropen[lbl1]: main.dooropensyst.dooropen.add.Out -> " ..
               "main.dooropensyst.motionctrl.redundancy.In" then found = true end
  end
  T.ok(found, "dooropen's Out (add, Out) to motionctrl's In (redundancy, In):\n" .. table.concat(seen, "\n"))
  T.eq(#conns, 20)
  local leaf, port = model.resolve(tree.children.dooropensyst, "dooropen", "Out")
  T.eq({ leaf.path, port }, { "main.dooropensyst.dooropen.add", "Out" })
  local none, why = model.resolve(tree.children.dooropensyst, "dooropen", "Nope")
  T.eq(none, nil)
  T.eq(why, "main.dooropensyst.dooropen (DoorOpen) exports no port 'Nope'")
end)

suite:case("supervision_policy_hosts_and_standby_reach_the_spec", function()
  local ast = assert(parser.parse([[
process Vision(h1, h1b, spare) {
  host { h1, h1b }
  supervision { strategy one_for_all; intensity 3 in 250 ms; restart on lost; standby cam on spare, "h9"; }
  instantiated_processes { cam instof Timer(h1, 1); servo instof Timer(h1, 2); }
  internal_event_actions { cam , servo }
}
process Plain(h) { host { h } instantiated_processes { t instof Timer(h, 1); } internal_event_actions { t } }
process main() {
  supervision { }
  instantiated_processes { v instof Vision("vision", "vision2", "spare1"); p instof Plain("h3"); }
  internal_event_actions { v , p }
}
]], "m.dca"))
  local tree = assert(model.build(ast))
  local v = tree.children.v
  T.eq(v.hosts, { "vision", "vision2" })
  T.eq(v.supervision, { strategy = "one_for_all", intensity = 3, within = 0.25,
                        on = { crash = false, lost = true, aborted = false } })
  T.eq(v.children.cam.standby, { "spare1", "h9" })
  T.eq(v.children.servo.standby, nil)
  -- an empty section: the defaults (OTP's: one restart in five seconds, on a crash or a lost host)
  T.eq(tree.supervision, { strategy = "one_for_one", intensity = 1, within = 5,
                           on = { crash = true, lost = true, aborted = false } })
  T.eq({ tree.children.p.supervision, tree.children.p.hosts }, { nil, { "h3" } })
  -- fencing: the defaults with or without a section
  T.eq({ tree.fence, v.fence, tree.children.p.fence }, { { fence = 5, margin = 1 }, { fence = 5, margin = 1 },
                                                         { fence = 5, margin = 1 } })
  local spec = require("dca.supervisor.spec").from_model(tree, "m.dca")
  local vs = spec.children[1].spec
  T.eq({ vs.hosts, vs.supervision.strategy, vs.supervision.within }, { { "vision", "vision2" }, "one_for_all", 0.25 })
  T.eq(vs.children[1].standby, { "spare1", "h9" })
  T.ok(vs.children[1].standby ~= v.children.cam.standby, "the spec shares nothing with the model")
  T.eq({ spec.children[2].spec.supervision, spec.children[2].spec.hosts }, { nil, { "h3" } })
  T.eq(spec.hosts, { spec.host }, "a root without host { } gets its host in hosts too")
  T.eq(vs.fence, { fence = 5, margin = 1 })
end)

suite:case("fence_clause_reaches_the_spec_in_seconds", function()
  local ast = assert(parser.parse([[
process main() {
  supervision { fence 1500 ms margin 0.25; }
  instantiated_processes { t instof Timer("h", 1); }
  internal_event_actions { t }
}
]], "f.dca"))
  local tree = assert(model.build(ast))
  T.eq(tree.fence, { fence = 1.5, margin = 0.25 })
  T.eq(require("dca.supervisor.spec").from_model(tree, "f.dca").fence, { fence = 1.5, margin = 0.25 })
end)

suite:case("rt_section_reaches_each_leaf_and_its_node_argv_inherited_by_groups_without_one", function()
  local ast = assert(parser.parse([[
process Arm(h) {
  host { h }
  rt { priority 80; cpu 1; }
  instantiated_processes { servo instof Timer(h, 1); }
  internal_event_actions { servo }
}
process Inner(h) { host { h } instantiated_processes { t instof Timer(h, 2); } internal_event_actions { t } }
process Fast(h) {
  host { h }
  rt { priority 90; }
  instantiated_processes { i instof Inner(h); }
  internal_event_actions { i }
}
process main() {
  instantiated_processes { a instof Arm("h1"); f instof Fast("h2"); slow instof Timer("h3", 3); }
  internal_event_actions { a , f , slow }
}
]], "rt.dca"))
  local cl = ast.by_name.Arm.rt.clauses
  T.eq({ ast.by_name.Arm.rt.line, ast.by_name.Arm.rt.col, #cl }, { 3, 3, 2 })
  T.eq({ cl[1].kw, cl[1].value, cl[1].value_line, cl[1].value_col, cl[2].kw, cl[2].value }, { "priority", 80, 3, 17, "cpu", 1 })
  T.eq(require("dca.lang.check").check(ast, { types = {} }), {})
  local spec = require("dca.supervisor.spec").from_model(assert(model.build(ast)), "rt.dca")
  local arm, fast, slow = spec.children[1].spec, spec.children[2].spec, spec.children[3]
  T.eq({ spec.rt, arm.rt, arm.children[1].rt }, { nil, { priority = 80, cpu = 1 }, { priority = 80, cpu = 1 } })
  -- Inner declares none: it takes Fast's, down to its leaf
  local inner = fast.children[1].spec
  T.eq({ fast.rt, inner.rt, inner.children[1].rt }, { { priority = 90 }, { priority = 90 }, { priority = 90 } })
  T.eq(slow.rt, nil)
  local net = require "dca.supervisor.net"
  local argv = net.child_argv(arm.children[1], "127.0.0.1:1")
  T.eq({ table.concat(argv, " ", 9) }, { "--rt-priority 80 --rt-cpu 1 -- 1" })
  argv = net.child_argv(inner.children[1], "127.0.0.1:1")
  T.eq({ table.concat(argv, " ", 9) }, { "--rt-priority 90 -- 2" })
  T.eq({ table.concat(net.child_argv(slow, "127.0.0.1:1"), " ", 9) }, { "-- 3" })
end)

return suite:run(...)
