-- dca graph's DOT: golden/graph_door_open.dot is exactly what dca.lang.graph prints for the door system
-- (worlds/door/systems/door_open.dca, without the registry), so a change of layout or labels is a reviewed diff.
-- DCA_GOLDEN_UPDATE=1 rewrites it (review the diff, and look at `dot -Tpng` of it).
local T = require "dca.testing"
local parser = require "dca.lang.parser"
local model = require "dca.lang.model"
local graph = require "dca.lang.graph"
local suite = T.suite("lang_graph")

local golden = T.here() .. "/golden/graph_door_open.dot"
local door = T.src .. "/worlds/door/systems/door_open.dca"

local function door_tree()
  local ast = assert(parser.parse(T.read(door), "door_open.dca"))
  local tree, errs = model.build(ast, { root = "main" })
  T.ok(tree, errs and errs[1] and errs[1].msg)
  return tree
end

suite:case("door_system_golden_dot", function()
  T.golden(golden, graph.dot(door_tree()))
end)

suite:case("config_parameters_print_as_written", function()
  local got = graph.dot(door_tree())
  T.ok(got:find('config(&quot;door.hit_force&quot;)', 1, true), "config(\"door.hit_force\") in the DOT")
  T.ok(not got:find("table: 0x", 1, true), "no table address in the DOT")
  T.ok(got:find('(&quot;open&quot;)', 1, true), "string parameters quoted")
end)

suite:case("one_cluster_per_group_hosts_shown", function()
  local got = graph.dot(door_tree())
  local clusters = 0
  for _ in got:gmatch('subgraph "cluster_') do clusters = clusters + 1 end
  T.eq(clusters, 6)  -- main, dooropensyst, dooropen, motionctrl, hit, distdetect
  T.ok(got:find("dooropensyst : DoorOpenSystem @manipulation", 1, true))
  T.ok(got:find("@vision", 1, true) and got:find("@platform", 1, true))
end)

suite:case("supervision_policy_and_standby_hosts_shown", function()
  local ast = assert(parser.parse([[
process V(h, hb) {
  host { h, hb }
  supervision { strategy rest_for_one; intensity 2 in 10 s; restart on crash, aborted; standby t on hb; fence 2; }
  instantiated_processes { t instof Timer(h, 1); }
  internal_event_actions { t }
}
process main() { instantiated_processes { v instof V("h1", "h2"); } internal_event_actions { v } }
]], "g.dca"))
  local got = graph.dot(assert(model.build(ast)))
  T.ok(got:find("v : V @h1 (standby h2)\\nrest_for_one, 2 in 10 s, on crash, aborted\\nfence 2 s, margin 1 s", 1, true),
       got)
  T.ok(not got:find("main : main[^\n]*fence"), "the default fence is not shown")
  T.ok(got:find("@h1 (standby h2)", 1, true))
end)

return suite:run(...)
