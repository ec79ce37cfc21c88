-- `dca graph` as a user runs it.
local T = require "dca.testing"
local suite = T.suite("graph")

local systems = T.src .. "/scripts/systems/"
local sprintf = string.format

suite:case("graph_writes_dot", function()
  local out = T.dca("graph --no-registry " .. systems .. "door_open.dca", 0,
    'subgraph "cluster_main.dooropensyst" {',
    "dooropensyst : DoorOpenSystem @manipulation\\nmotionctrl # ((visualserv[lbl1], camera) # distdetect ;",
    'subgraph "cluster_main.dooropensyst.hit" {',
    '"main.dooropensyst.visualserv":o_Vel:s -> "main.dooropensyst.motionctrl.redundancy":i_In:n',
    'config(&quot;door.hit_force&quot;)',
    'opengrip : GripperControl<BR/>@manipulation<BR/>(&quot;open&quot;)')
  T.ok(not out:find("table: 0x", 1, true), out)
  T.ok(out:match("^digraph dca {\n"), out)
end)

suite:case("graph_checks_device_ports_against_the_world_of_sim", function()
  local file, urdf = T.src .. "/worlds/ur10/ur10_setpoint.dca", T.src .. "/worlds/ur10/ur10.urdf"
  T.dca("graph " .. file .. " --sim " .. urdf, 0, '"main.elbow" [label=<', "elbow : JointSetpoint<BR/>@arm")
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

local door = T.src .. "/worlds/door/systems/door_open.dca"

-- The edges of DOT text: { from, fport, to, tport, attrs } (fport/tport nil for an edge not on ports).
local function edges(dot)
  local list = {}
  for line in dot:gmatch("[^\n]+") do
    local lhs, rhs, attrs = line:match('^%s*("[^"]+"[^%s]*) %-> ("[^"]+"[^%s]*) %[(.*)%];$')
    if lhs then
      local from, fport = lhs:match('^"([^"]+)":?([%w_]*)')
      local to, tport = rhs:match('^"([^"]+)":?([%w_]*)')
      list[#list + 1] = { from = from, fport = fport ~= "" and fport or nil, to = to,
                          tport = tport ~= "" and tport or nil, attrs = attrs }
    end
  end
  return list
end

suite:case("graph_puts_ports_on_the_leaves_and_edges_on_ports", function()
  local dot = T.dca("graph " .. door, 0, '<TD PORT="o_Vel"', '<TD PORT="i_In"')
  local n = 0
  for _, e in ipairs(edges(dot)) do
    if not e.attrs:find("style=invis", 1, true) then
      n = n + 1
      T.ok(e.fport and e.tport, "an edge between ports: " .. e.from .. " -> " .. e.to)
      local port = e.from == "world" and e.fport or e.tport
      T.ok(dot:find('PORT="' .. port .. '"', 1, true), "the port is declared: " .. port)
    end
  end
  T.ok(n >= 20, "the door's connections and device ports: " .. n)
  T.contains(dot, '"main.dooropensyst.camera":o_Feature:s -> "main.dooropensyst.visualserv":i_Feature:n')
  -- through external_io: visualserv's Vel reaches motionctrl's redundancy
  T.contains(dot, '"main.dooropensyst.visualserv":o_Vel:s -> "main.dooropensyst.motionctrl.redundancy":i_In:n')
end)

suite:case("graph_draws_the_world_and_its_device_ports", function()
  local dot = T.dca("graph " .. door .. " --sim door", 0, '"world" [label=<', "<B>world: door</B>",
    'PORT="s_laser_range"', 'PORT="c_base_cmd_vel"')
  T.contains(dot, '"world":s_laser_range:s -> "main.dooropensyst.distdetect.laser":i_Raw:n')
  T.contains(dot, '"main.dooropensyst.motionctrl.xr4000":o_Cmd:s -> "world":c_base_cmd_vel:n')
  -- no device ports, no --sim: no world
  local tidy = T.dca("graph --no-registry " .. systems .. "tidy_up.dca", 0)
  T.ok(not tidy:find('"world"', 1, true), tidy)
end)

suite:case("graph_fills_each_host_with_its_colour_and_a_legend", function()
  local dot = T.dca("graph " .. door, 0, '"legend" [label=<')
  local legend = dot:match('"legend" %[label=(.-)%];')
  local colours, hosts = {}, {}
  for c, host in legend:gmatch('<TD BGCOLOR="(#%x+)">@([%w_]+)</TD>') do
    T.ok(not colours[c], "one colour per host: " .. c) colours[c] = host hosts[host] = c
  end
  for _, host in ipairs({ "vision", "manipulation", "platform" }) do T.ok(hosts[host], "legend names " .. host) end
  -- each leaf is filled with its host's colour
  local leaves = 0
  for line in dot:gmatch("[^\n]+") do
    local path, colour, host = line:match('^%s*"([^"]+)" %[label=<<TABLE [^>]-BGCOLOR="(#%x+)">.-<BR/>@([%w_]+)')
    if path and path ~= "world" then T.eq(colour, hosts[host], path) leaves = leaves + 1 end
  end
  T.ok(leaves >= 20, "leaves checked: " .. leaves)
end)

suite:case("graph_flow_mode_has_the_leaves_and_their_connections_only", function()
  local dot = T.dca("graph " .. door .. " --flow", 0, '"main.dooropensyst.camera" [label=<')
  T.ok(not dot:find("subgraph", 1, true), "no clusters")
  T.ok(not dot:find("style=invis", 1, true), "no ordering edges")
  T.ok(not dot:find("motionctrl # ", 1, true), "no expressions")
  T.contains(dot, '"main.dooropensyst.camera":o_Feature:s -> "main.dooropensyst.visualserv":i_Feature:n')
end)

-- The boxes of an SVG from dot: the nodes' (from their polygons) and the edge labels' (from their text: x is
-- the middle, y the baseline; a character of the 9 pt font at most 0.62 of its size wide).
local function boxes(svg)
  local nodes, labels = {}, {}
  for kind, body in svg:gmatch('<g id="%w+" class="(%w+)">(.-)</g>') do
    if kind == "node" then
      local b = { x0 = math.huge, y0 = math.huge, x1 = -math.huge, y1 = -math.huge }
      for pts in body:gmatch('points="([^"]+)"') do
        for x, y in pts:gmatch("(%-?[%d.]+),(%-?[%d.]+)") do
          x, y = tonumber(x), tonumber(y)
          b.x0, b.x1, b.y0, b.y1 = math.min(b.x0, x), math.max(b.x1, x), math.min(b.y0, y), math.max(b.y1, y)
        end
      end
      if b.x0 < b.x1 then b.name = body:match("<title>(.-)</title>") nodes[#nodes + 1] = b end
    elseif kind == "edge" then
      for x, y, size, text in body:gmatch('<text text%-anchor="middle" x="(%-?[%d.]+)" y="(%-?[%d.]+)"[^>]-'
                                          .. 'font%-size="([%d.]+)">(.-)</text>') do
        x, y, size = tonumber(x), tonumber(y), tonumber(size)
        local w = #text * size * 0.62
        labels[#labels + 1] = { x0 = x - w / 2, x1 = x + w / 2, y0 = y - size, y1 = y + 2, name = text }
      end
    end
  end
  return nodes, labels
end

suite:case("graph_edge_labels_never_overlap_the_boxes", function()
  local _, has_dot = T.sh("command -v dot")
  if has_dot ~= 0 then return end  -- graph_svg_when_dot_is_installed says why
  local files = { door }
  local ls = io.popen("ls " .. systems .. "*.dca")
  for f in ls:lines() do files[#files + 1] = f end
  ls:close()
  local checked = 0
  for i = 1, 2 * #files do
    local file, mode = files[(i + 1) // 2], i % 2 == 0 and " --flow" or ""
    local out_path = T.tmpname(".svg")
    T.dca("graph --svg -o " .. out_path .. mode .. " " .. file, 0)
    local nodes, labels = boxes(T.read(out_path))
    os.remove(out_path)
    T.ok(#nodes > 0, file .. ": nodes in the SVG")
    for _, l in ipairs(labels) do
      for _, n in ipairs(nodes) do
        local overlap = l.x0 < n.x1 and n.x0 < l.x1 and l.y0 < n.y1 and n.y0 < l.y1
        T.ok(not overlap, sprintf("%s%s: edge label %s over node %s", file, mode, l.name, tostring(n.name)))
      end
      checked = checked + 1
    end
  end
  T.ok(checked >= 40, "edge labels checked: " .. checked)
end)

suite:case("usage_errors_exit_2", function()
  T.dca("graph", 2, "usage: dca graph FILE.dca")
  T.dca("graph -o", 2, "dca graph: -o needs a value")
  T.dca("graph --frob x.dca", 2, "dca graph: unknown option '--frob'")
end)

return suite:run(...)
