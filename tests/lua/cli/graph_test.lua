-- `dca graph` as a user runs it.
local T = require "dca.testing"
local suite = T.suite("graph")

local systems = T.src .. "/scripts/systems/"

suite:case("graph_writes_dot", function()
  local out = T.dca("graph --no-registry " .. systems .. "door_open.dca", 0,
    'subgraph "cluster_main.dooropensyst" {',
    "dooropensyst : DoorOpenSystem @manipulation\\nmotionctrl # ((visualserv[lbl1], camera) # distdetect ;",
    'subgraph "cluster_main.dooropensyst.hit" {',
    '"main.dooropensyst.visualserv" -> "main.dooropensyst.motionctrl" [style=dotted',
    'config(\\"door.hit_force\\")',
    '"main.dooropensyst.opengrip" [label="opengrip : GripperControl\\n@manipulation\\n(\\"open\\")"];')
  T.ok(not out:find("table: 0x", 1, true), out)
  T.ok(out:match("^digraph dca {\n"), out)
end)

suite:case("graph_checks_device_ports_against_the_world_of_sim", function()
  local file, urdf = T.src .. "/worlds/ur10/ur10_setpoint.dca", T.src .. "/worlds/ur10/ur10.urdf"
  T.dca("graph " .. file .. " --sim " .. urdf, 0, '"main.elbow" [label="elbow : JointSetpoint')
  T.dca("graph " .. file, 1, "the world has no command 'joint.elbow_joint.position_command'")
end)

suite:case("graph_svg_when_dot_is_installed", function()
  local _, has_dot = T.sh("command -v dot")
  local out_path = T.tmpname(".svg")
  local args = "graph --no-registry --svg -o " .. out_path .. " " .. systems .. "tidy_up.dca"
  if has_dot ~= 0 then
    T.dca(args, 1, "not installed")
    return
  end
  T.dca(args, 0)
  local svg = T.read(out_path)
  os.remove(out_path)
  T.contains(svg, "<svg")
  T.contains(svg, "main.tidy")
end)

suite:case("usage_errors_exit_2", function()
  T.dca("graph", 2, "usage: dca graph FILE.dca")
  T.dca("graph -o", 2, "dca graph: -o needs a value")
  T.dca("graph --frob x.dca", 2, "dca graph: unknown option '--frob'")
end)

return suite:run(...)
