-- dca.lang.ports: which output can feed which input, the sizes worked out for the built-ins, device ports.
-- Through dca.lang.model.build, as `dca check` runs it, against a fixed registry in the shape of core.types().
local T = require "dca.testing"
local parser = require "dca.lang.parser"
local model = require "dca.lang.model"
local ports = require "dca.lang.ports"
local suite = T.suite("ports")

local function port(name, ty, size, device) return { name = name, type = ty, size = size or 0, device = device } end
local function msg(name, message) return { name = name, type = "message", size = 0, message = message } end
local function number(name, variadic) return { name = name, type = "number", required = not variadic, variadic = variadic } end

local registry = {
  Constant = { inputs = {}, outputs = { port("Out", "vectorx") }, params = { number("period"), number("values", true) } },
  Gain = { inputs = { port("In", "vectorx") }, outputs = { port("Out", "vectorx") }, params = { number("k") } },
  Sum = { inputs = { port("In1", "vectorx"), port("In2", "vectorx") }, outputs = { port("Out", "vectorx") }, params = {} },
  Counter = { inputs = {}, outputs = { port("Count", "scalar", 1) }, params = { number("period") } },
  Level = { inputs = { port("In", "scalar", 1) }, outputs = {}, params = {} },
  Pose = { inputs = {}, outputs = { port("Pose", "vector", 3) }, params = {} },
  Single = { inputs = { port("In", "vector", 1) }, outputs = { port("Out", "vector", 1) }, params = {} },
  Any = { inputs = { port("In", "vectorx") }, outputs = { port("Out", "vectorx") }, params = {}, package = "lab" },
  Note = { inputs = { port("In", "value") }, outputs = { port("Msg", "value") }, params = {} },
  Teleop = { inputs = {}, outputs = { msg("Cmd", "geometry_msgs/msg/Twist") }, params = {} },
  Base = { inputs = { msg("CmdVel", "geometry_msgs/msg/Twist"), msg("Push", "geometry_msgs/msg/Wrench") },
           outputs = {}, params = {} },
  Drive = { inputs = { port("Odom", "vector", 2, "base.pose") }, outputs = { port("Cmd", "vector", 3, "base.cmd_vel"),
            port("Grip", "vector", 1, "gripper.cmd") }, params = {} },
  Probe = { inputs = { port("Q", "vector", 6, "arm.qq") }, outputs = {}, params = {} },
  Joint = { inputs = { port("Q", "vector", 1, "joint.{joint}.position") },
            outputs = { port("Cmd", "vector", 1, "joint.{joint}.{interface}_command") },
            params = { { name = "joint", type = "string", required = true },
                       { name = "interface", type = "string", required = false, default = "position" } } },
  Wide = { inputs = { port("Q", "vector", 2, "joint.{joint}.position"), port("Counts", "vector", 6, "safety.clamps") },
          outputs = { port("Cmd", "vector", 3, "joint.{joint}.position_command") },
          params = { { name = "joint", type = "string", required = true } } },
  Arm = { inputs = { port("Q1", "vector", 1, "joint.{joints[1]}.position"),
                     port("Q2", "vector", 1, "joint.{joints[2]}.position"),
                     port("Q3", "vector", 1, "joint.{joints[3]}.position") },
          outputs = { port("Cmd3", "vector", 1, "joint.{joints[3]}.{interface}_command") },
          params = { { name = "joints", type = "string", required = true },
                     { name = "interface", type = "string", required = false, default = "position" } } },
  Typo = { inputs = { port("Q", "vector", 1, "joint.{jont}.position") }, outputs = {},
           params = { { name = "joint", type = "string", required = true } } },
}

local world = {
  outputs = { ["base.pose"] = port("base.pose", "vector", 3), ["arm.q"] = port("arm.q", "vector", 6),
              ["joint.elbow.position"] = port("joint.elbow.position", "vector", 1) },
  inputs = { ["base.cmd_vel"] = port("base.cmd_vel", "vector", 3), ["gripper.cmd"] = port("gripper.cmd", "vector", 1),
             ["joint.elbow.position_command"] = port("joint.elbow.position_command", "vector", 1) },
}

--- The errors of `body` (the instances, connections and expression of process main) as "line:col: msg".
local function errors_of(body, w)
  local ast = assert(parser.parse("process main() {\n" .. body .. "\n}\n", "t.dca"))
  local tree, errs = model.build(ast, { types = registry, world = w })
  local out = {}
  for i, e in ipairs(tree and {} or errs) do out[i] = string.format("%d:%d: %s", e.line, e.col, e.msg) end
  return out
end

suite:case("the_rules_of_fits", function()
  local S, V, X, VAL = { kind = "scalar", size = 1 }, function(n) return { kind = "vector", size = n } end,
                       function(n) return { kind = "vectorx", size = n } end, { kind = "value" }
  local cases = {
    { S, S, true }, { S, V(1), true }, { V(1), S, true }, { S, V(2), false }, { V(3), V(3), true },
    { V(3), V(2), false }, { V(3), X(), true }, { S, X(), true }, { X(), X(), true }, { X(3), V(3), true },
    { X(3), S, false }, { X(1), S, true }, { X(), S, false }, { X(), V(3), false }, { VAL, VAL, true },
    { VAL, S, false }, { S, VAL, false }, { VAL, X(), false },
  }
  for _, c in ipairs(cases) do
    T.eq(ports.fits(c[1], c[2]) == true, c[3], ports.text(c[1]) .. " -> " .. ports.text(c[2]))
  end
  T.eq(select(2, ports.fits(X(), S)), ": dca check cannot tell how many values it writes")
  T.eq({ ports.text(S), ports.text(V(3)), ports.text(X()), ports.text(X(2)), ports.text(VAL) },
       { "scalar", "vector[3]", "vectorx", "vectorx of size 2", "value" })
  T.eq(ports.shape({ name = "In1" }), nil, "a manifest without types: nothing to check")
end)

suite:case("scalars_meet_the_built_ins_that_take_their_size_from_what_feeds_them", function()
  T.eq(errors_of([[
  instantiated_processes {
    c instof Constant("h", 0, 2.5); n instof Counter("h", 1); s instof Sum("h"); g instof Gain("h", 2);
    l instof Level("h"); m instof Level("h"); o instof Single("h"); a instof Any("h");
  }
  internal_connections(s, x) { c, Out -> s, In1; n, Count -> s, In2; }
  internal_connections(g, x) { s, Out -> g, In; g, Out -> l, In; g, Out -> o, In; }
  internal_connections(m, x) { c, Out -> m, In; }
  internal_connections(o, x) { o, Out -> a, In; }
  internal_event_actions { s[x], g[x], c, n, l, m[x], o[x], a }]]), {})
end)

suite:case("every_mismatch_names_both_ends_and_both_types_at_the_connection", function()
  T.eq(errors_of([[
  instantiated_processes {
    c instof Constant("h", 0, 1, 2, 3); a instof Any("h"); l instof Level("h"); p instof Pose("h");
    o instof Single("h"); note instof Note("h"); g instof Gain("h", 2); loop instof Gain("h", 1);
  }
  internal_connections(l, x) {
    c, Out -> l, In;
    a, Out -> l, In;
    note, Msg -> l, In;
  }
  internal_connections(o, x) { p, Pose -> o, In; }
  internal_connections(note, x) { c, Out -> note, In; }
  internal_connections(g, x) { c, Out -> g, In; g, Out -> o, In; }
  internal_connections(loop, x) { loop, Out -> loop, In; loop, Out -> l, In; }
  internal_event_actions { l[x], c, a, p, o[x], note[x], g[x], loop[x] }]]), {
    "7:5: main.c.Out (vectorx of size 3) cannot feed main.l.In (scalar)",
    "8:5: main.a.Out (vectorx) cannot feed main.l.In (scalar): dca check cannot tell how many values it writes",
    "9:5: main.note.Msg (value) cannot feed main.l.In (scalar)",
    "11:32: main.p.Pose (vector[3]) cannot feed main.o.In (vector[1])",
    "12:35: main.c.Out (vectorx of size 3) cannot feed main.note.In (value)",
    "13:49: main.g.Out (vectorx of size 3) cannot feed main.o.In (vector[1])",
    "14:58: main.loop.Out (vectorx) cannot feed main.l.In (scalar): dca check cannot tell how many values it writes",
  })
end)

suite:case("a_message_feeds_only_a_message_of_its_own_type", function()
  local twist = { kind = "message", message = "geometry_msgs/msg/Twist" }
  local wrench = { kind = "message", message = "geometry_msgs/msg/Wrench" }
  T.eq(ports.shape(msg("Cmd", "geometry_msgs/msg/Twist")), twist)
  T.eq(ports.fits(twist, twist), true)
  T.eq(ports.fits(twist, wrench), false)
  T.eq(ports.fits(twist, { kind = "value" }), false)
  T.eq(ports.fits({ kind = "vectorx" }, twist), false)
  T.eq(errors_of([[
  instantiated_processes { t instof Teleop("h"); b instof Base("h"); l instof Level("h"); note instof Note("h"); }
  internal_connections(b, x) {
    t, Cmd -> b, CmdVel;
    t, Cmd -> b, Push;
    note, Msg -> b, CmdVel;
  }
  internal_connections(l, x) { t, Cmd -> l, In; }
  internal_event_actions { b[x], t, l[x], note }]]), {
    "5:5: main.t.Cmd (geometry_msgs/msg/Twist) cannot feed main.b.Push (geometry_msgs/msg/Wrench)",
    "6:5: main.note.Msg (value) cannot feed main.b.CmdVel (geometry_msgs/msg/Twist)",
    "8:32: main.t.Cmd (geometry_msgs/msg/Twist) cannot feed main.l.In (scalar)",
  })
end)

suite:case("ends_behind_external_io_are_named_as_written_and_as_resolved_once_per_position", function()
  local ast = assert(parser.parse([[
process Sensing(h) {
  instantiated_processes { p instof Pose(h); }
  external_io { Out = p, Pose; }
  internal_event_actions { p }
}
process Arm(h) {
  instantiated_processes { l instof Level(h); s instof Sensing(h); }
  external_io { In = l, In; }
  internal_connections(l, x) { s, Out -> l, In; }
  internal_event_actions { l[x], s }
}
process main() {
  instantiated_processes { s instof Sensing("h"); a instof Arm("h"); b instof Arm("h"); }
  internal_connections(a, x) { s, Out -> a, In; }
  internal_event_actions { a[x], s, b }
}
]], "t.dca"))
  local _, errs = model.build(ast, { types = registry })
  T.eq(#errs, 2, "the connection inside Arm once, though Arm is instantiated twice")
  T.eq({ errs[1].line, errs[1].col, errs[1].msg },
       { 9, 32, "main.a.s.Out (vector[3], main.a.s.p.Pose) cannot feed main.a.l.In (scalar)" })
  T.eq({ errs[2].line, errs[2].col, errs[2].msg },
       { 14, 32, "main.s.Out (vector[3], main.s.p.Pose) cannot feed main.a.In (scalar, main.a.l.In)" })
end)

suite:case("device_ports_are_held_to_the_world_s_signals", function()
  local body = [[
  instantiated_processes { d instof Drive("h"); q instof Probe("h"); }
  internal_event_actions { d, q }]]
  T.eq(errors_of(body, world), {
    "2:28: world.base.pose (vector[3]) cannot feed main.d.Odom (vector[2], device port of Drive)",
    "2:49: main.q.Q (vector[6], device port of Probe): the world has no sensor 'arm.qq'",
  })
  T.eq(errors_of(body, nil), {}, "without the world's signals, nothing to hold them to")
end)

suite:case("device_signals_named_after_parameters_take_the_leaf_s_arguments_or_defaults", function()
  local params = registry.Joint.params
  T.eq(ports.device_signal("joint.{joint}.{interface}_command", params, { "elbow", "velocity" }),
       "joint.elbow.velocity_command")
  T.eq(ports.device_signal("joint.{joint}.{interface}_command", params, { "elbow" }), "joint.elbow.position_command",
       "the default")
  T.eq(ports.device_signal("arm.q", params, {}), "arm.q", "no braces: the signal as it is")
  T.eq({ ports.device_signal("joint.{jont}.position", params, { "elbow" }) },
       { nil, "its device signal joint.{jont}.position names no parameter 'jont'" })
  T.eq({ ports.device_signal("joint.{joint}.position", params, { { config = "arm.joint" } }) },
       { nil, "its device signal joint.{joint}.position needs a literal argument 'joint'" })
end)

suite:case("a_numbered_word_of_an_argument_names_a_slot_and_a_missing_word_leaves_it_unwired", function()
  local params = registry.Arm.params
  T.eq(ports.device_signal("joint.{joints[2]}.{interface}_command", params, { "elbow wrist,tool", "velocity" }),
       "joint.wrist.velocity_command", "words are separated by spaces or commas")
  T.eq(ports.device_signal("joint.{joints[3]}.position", params, { "elbow, wrist,  tool" }), "joint.tool.position")
  T.eq(ports.device_signal("joint.{joints[4]}.position", params, { "elbow wrist tool" }), false, "no fourth word")
  T.eq(ports.device_signal("joint.{joints[1]}.position", params, { "" }), false, "no word at all")
  T.eq({ ports.device_signal("joint.{jonts[1]}.position", params, { "elbow" }) },
       { nil, "its device signal joint.{jonts[1]}.position names no parameter 'jonts'" })
  T.eq({ ports.device_signal("joint.{joints[1]}.position", params, { { config = "arm.joints" } }) },
       { nil, "its device signal joint.{joints[1]}.position needs a literal argument 'joints'" })
  -- two joints of a three-slot type: the third slot is no device port, so nothing to hold to the world
  T.eq(errors_of([[
  instantiated_processes { a instof Arm("h", "elbow wrist"); }
  internal_event_actions { a }]], world), {
    "2:28: main.a.Q2 (vector[1], device port of Arm): the world has no sensor 'joint.wrist.position'",
  })
end)

suite:case("a_template_naming_a_missing_parameter_or_signal_is_an_error_at_the_leaf", function()
  T.eq(errors_of([[
  instantiated_processes {
    e instof Joint("h", "elbow");
    w instof Joint("h", "wrist", "velocity");
    t instof Typo("h", "elbow");
    c instof Joint("h", config("arm.joint"));
  }
  internal_event_actions { e, w, t, c }]], world), {
    "4:5: main.w.Cmd (vector[1], device port of Joint): the world has no command 'joint.wrist.velocity_command'",
    "4:5: main.w.Q (vector[1], device port of Joint): the world has no sensor 'joint.wrist.position'",
    "5:5: main.t.Q (vector[1], device port of Typo): its device signal joint.{jont}.position names no parameter 'jont'",
    "6:5: main.c.Cmd (vector[1], device port of Joint): its device signal joint.{joint}.{interface}_command needs a "
      .. "literal argument 'joint'",
    "6:5: main.c.Q (vector[1], device port of Joint): its device signal joint.{joint}.position needs a literal "
      .. "argument 'joint'",
  })
end)

suite:case("the_size_rules_name_the_registry_s_ports_and_the_world_s_signals_are_known", function()
  local core = require "dca.core"
  local types = core.types()
  local function find(list, name)
    for _, p in ipairs(list) do if p.name == name then return p end end
  end
  for ty, outs in pairs(ports.sizes) do
    local m = assert(types[ty], ty)
    T.eq(m.package, nil, ty .. " is built in")
    for name, rule in pairs(outs) do
      T.eq(assert(find(m.outputs, name), ty .. "." .. name).type, "vectorx", ty .. "." .. name)
      if rule.values then T.ok(assert(find(m.params, rule.values)).variadic, ty .. " " .. rule.values) end
      for _, i in ipairs(rule.inputs or {}) do T.eq(assert(find(m.inputs, i), ty .. "." .. i).type, "vectorx") end
    end
  end
  -- the robot process's signals (sim/world.h) as dca check holds the device ports to them
  local w = assert(core.world_signals(), "the dca executable has the world")
  T.eq({ w.outputs["arm.q"].type, w.outputs["arm.q"].size }, { "vector", 6 })
  T.eq({ w.inputs["base.cmd_vel"].type, w.inputs["base.cmd_vel"].size }, { "vector", 3 })
  T.eq(w.inputs["arm.q"], nil, "a sensor is no command")
  T.eq(core.world_signals("door"), w, "door is the default")
end)

-- A URDF world's signals (core.world_signals(SPEC), docs/robots.md "Ports"): the check holds device ports to the
-- joints' interfaces, their sizes included.
suite:case("a_device_port_of_another_size_than_a_urdf_joint_interface_is_an_error", function()
  local core = require "dca.core"
  local w = assert(core.world_signals(T.src .. "/worlds/ur10/ur10.urdf"))
  T.eq({ w.outputs["joint.elbow_joint.position"].type, w.outputs["joint.elbow_joint.position"].size }, { "vector", 1 })
  T.eq(w.inputs["joint.elbow_joint.velocity_command"].size, 1)
  T.eq(w.outputs["safety.clamps"].size, 12, "one count per command input")
  T.eq(w.inputs["joint.elbow_joint.effort_command"], nil, "the UR10 declares no effort command")
  T.eq(errors_of([[
  instantiated_processes { ok instof Joint("h", "elbow_joint", "velocity"); wide instof Wide("h", "elbow_joint"); }
  internal_event_actions { ok, wide }]], w), {
    "2:77: main.wide.Cmd (vector[3], device port of Wide) cannot feed world.joint.elbow_joint.position_command (vector[1])",
    "2:77: world.joint.elbow_joint.position (vector[1]) cannot feed main.wide.Q (vector[2], device port of Wide)",
    "2:77: world.safety.clamps (vector[12]) cannot feed main.wide.Counts (vector[6], device port of Wide)",
  })
end)

return suite:run(...)
