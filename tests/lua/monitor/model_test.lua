-- dca.monitor.model: the tree, the events from lines (states, faults, restarts), expressions as operator trees,
-- the configuration, snapshots and deltas.
local T = require "dca.testing"
local model = require "dca.monitor.model"
local suite = T.suite("monitor_model")

local TREE = {
  path = "main", kind = "group", type = "Main", host = "h1", state = "running", expr = "*g* ; b",
  children = {
    { path = "main.g", kind = "group", type = "G", host = "h2", state = "running", expr = "x # y[l1]",
      children = { { path = "main.g.x", kind = "leaf", type = "X", host = "h2", state = "running" },
                   { path = "main.g.y", kind = "leaf", type = "Y", host = "h3", state = "inactive" } } },
    { path = "main.b", kind = "leaf", type = "B", host = "h1", state = "inactive" },
  },
}

-- The tree gives every process with its host, and each group's expression as an operator tree.
suite:case("tree_gives_hosts_and_expression_trees", function()
  local m = model.new()
  m:tree(TREE, 0)
  local s = m:snapshot()
  T.eq(#s.nodes, 5)
  T.eq(s.nodes[1].path, "main")
  T.eq(m.nodes["main.g.y"].host, "h3")
  T.eq(m.nodes["main.g"].kind, "group")
  T.eq(s.exprs["main.g"], { op = "#", kids = { { op = "leaf", name = "x" }, { op = "leaf", name = "y", label = "l1" } } })
  T.eq(s.exprs["main"].op, ";", "the running marks *g* are not part of the expression")
  T.eq(m.root, "main")
end)

-- Transition lines become events: states, faults with their reasons, restarts.
suite:case("lines_become_events_faults_restarts", function()
  local m = model.new("main")
  m:tree(TREE, 0)
  m:take_delta()
  m:line("main.g.x: done 0.5", 1.5)
  m:line("main.g.y: exited: signal 11 (SIGSEGV)", 2)
  m:line("main.g.y: restarting", 2.1)
  m:line("main.g.y: restarted (pid 42)", 2.2)
  m:line("main.g: aborted (main.g.y: lost its host)", 3)
  m:line("world: starting `dca sim`", 3)          -- not a process of the tree
  m:line("main: the whole tree is configured: run", 3)
  T.eq(m.nodes["main.g.x"].state, "done")
  T.eq(m.nodes["main.g.y"].state, "running")
  T.eq(m.nodes["main.g.y"].restarts, 1)
  T.eq(m.nodes["main.g.y"].fault, "signal 11 (SIGSEGV)")
  T.eq(m.nodes["main.g"].fault, "main.g.y: lost its host")
  T.eq(m.nodes.world, nil)
  local d = m:take_delta()
  T.eq(#d.lines, 7)
  T.eq(d.events[1], { t = 1.5, path = "main.g.x", state = "done" })
  T.eq(d.t, 3)
  T.eq(m:take_delta(), nil, "nothing changed since")
end)

-- The root's outcome line (what `dca run` says last, "main: ABORTED at ...", "main: DONE ...") is the root's own
-- event: a page sees the root end before the run closes it, whether or not the tree was asked for again.
suite:case("the_roots_outcome_is_its_last_event", function()
  local m = model.new("main")
  m:tree(TREE, 0)
  m:line("main: ABORTED at main.b: aborted from the monitor", 4)
  T.eq(m.nodes.main.state, "aborted")
  T.eq(m.nodes.main.fault, "at main.b: aborted from the monitor")
  local d = model.new("main")
  d:tree(TREE, 0)
  d:line("main: DONE 1", 4)
  T.eq(d.nodes.main.state, "done")
end)

-- The configuration and the last lines are kept for a new page.
suite:case("config_and_last_lines_kept", function()
  local m = model.new("main")
  m:set_config("door.width", "0.9", "h1/ab")
  for i = 1, model.MAX_LINES + 10 do m:line("line " .. i, i) end
  local s = m:snapshot()
  T.eq(s.config, { { key = "door.width", value = "0.9", origin = "h1/ab" } })
  T.eq(#s.lines, model.MAX_LINES)
  T.eq(s.lines[#s.lines].line, "line " .. (model.MAX_LINES + 10))
end)

-- The events are bounded: the oldest go first.
suite:case("events_bounded_oldest_first", function()
  local m = model.new("main")
  local saved = model.MAX_EVENTS
  model.MAX_EVENTS = 100
  for i = 1, 250 do m:line(i % 2 == 0 and "main.a: running" or "main.a: done 1", i) end
  model.MAX_EVENTS = saved
  T.ok(#m.events <= 100, #m.events)
  T.eq(m.events[#m.events].t, 250)
end)

-- An expression that does not parse gives no operator tree.
suite:case("bad_expression_gives_no_tree", function()
  T.eq(model.expr_tree("a ; ; b"), nil)
  T.eq(model.expr_tree(nil), nil)
  T.eq(model.expr_tree("a , b").op, ",")
end)

return suite:run(...)
