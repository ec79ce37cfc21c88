-- `dca plot` as a user runs it: on a short run recorded with its ports (--record-ports), and on `dca sim`'s
-- recordings (MCAP and CSV).
local T = require "dca.testing"
local suite = T.suite("plot")

-- A laser on the robot (its Distance output recorded) until a Timer ends the run after 0.5 s.
local LASER = T.src .. "/tests/lua/cli/systems/laser_until_timer.dca"

-- The recording of a short run with its ports' channels.
local function run_recording()
  local mcap = T.tmpname(".mcap")
  T.dca("run " .. LASER .. " --sim door --seed 1 --record " .. mcap .. " --record-ports all", 0,
        "/main/laser/Distance")
  return mcap
end

suite:case("list_names_the_port_channels_the_world_signals_and_the_steps", function()
  local out = T.dca("plot " .. run_recording() .. " --list", 0, "/world/door/angle[0]  ", "/world/wrist/wrench[0]  ",
                    "step 0.000 s  main.laser", "step 0.000 s  main.stop")
  local n = tonumber(out:match("/main/laser/Distance  (%d+) samples"))
  T.ok(n and n >= 40, "the port's samples over 0.5 s at the 10 ms period:\n" .. out)
  T.ok(not out:find("/dca/", 1, true), "the run's own channels are no signals:\n" .. out)
end)

suite:case("signals_chosen_by_pattern_are_drawn_as_steps_with_the_run_steps_marked", function()
  local mcap = run_recording()
  local script = T.tmpname(".gnuplot")
  T.dca("plot " .. mcap .. " --signal '/main/*' --signal '/world/laser/*' --script " .. script, 0, script)
  local g, data = T.read(script), T.read(script .. ".dat")
  -- each with its unit from the recording's schema (the manifest's)
  T.contains(g, "index 0 using 1:2 with steps lw 1.5 title '/main/laser/Distance (m)'")
  T.contains(g, "index 1 using 1:2 with steps lw 1.5 title '/world/laser/range[0] (m)'")
  T.contains(g, "set multiplot layout 2,1")  -- a panel per topic
  T.contains(g, "set arrow from 0, graph 0 to 0, graph 1 nohead dt 2")
  -- one mark at 0 for the two processes starting then, named
  local label = g:match("set label '([%w, ]+)' at 0, graph 0.98 rotate by 90")
  T.ok(label == "stop, laser" or label == "laser, stop", "the mark at 0: " .. tostring(label) .. "\n" .. g)
  T.eq(select(2, g:gsub("set arrow from", "")), 2, "one mark in each of the two panels:\n" .. g)
  T.ok(not g:find("/world/arm", 1, true), "only the chosen signals:\n" .. g)
  -- the data: one block per signal, time and value
  T.ok(data:match("^# /main/laser/Distance\n[%d.e%-]+ [%d.e%-]+\n"), data:sub(1, 200))
  T.contains(data, "\n\n\n# /world/laser/range[0]\n0 ")
  T.dca("plot " .. mcap .. " --signal '/main/nothing*'", 1, "no signal matches '/main/nothing*' (--list lists them)")
end)

-- A dca run's recording holds the world's signals one channel each, as live: the door's by default all the same.
suite:case("a_dca_run_recording_plots_the_door_by_default", function()
  local script = T.tmpname(".gnuplot")
  T.dca("plot " .. run_recording() .. " --script " .. script, 0)
  local g = T.read(script)
  T.contains(g, "title '/world/door/angle[0] (rad)'")  -- the manifest's unit: radians, as the world has them
  T.contains(g, "title '/world/wrist/wrench[0] (N, N m)'")
  T.contains(g, "title '/world/base/pose[1] (m)'", "one unit per element: \"m, m, rad\"'s second")
  T.ok(not g:find("/world/arm/q", 1, true), "the door's signals by default:\n" .. g)
end)

suite:case("a_png_is_written_with_gnuplot", function()
  local _, has = T.sh("command -v gnuplot")
  if has ~= 0 then T.dca("plot " .. run_recording(), 1, "gnuplot") return end
  local png = T.tmpname(".png")
  T.dca("plot " .. run_recording() .. " --signal '/main/*' -o " .. png, 0, png)
  T.eq(T.read(png):sub(1, 4), "\137PNG")
  T.ok(not io.open(png .. ".gnuplot"), "the script is removed")
end)

suite:case("a_dca_sim_recording_plots_the_door_by_default_mcap_and_csv", function()
  local mcap, csv, script = T.tmpname(".mcap"), T.tmpname(".csv"), T.tmpname(".gnuplot")
  T.dca("sim --duration 0.2 --record " .. mcap, 0)
  T.dca("plot " .. mcap .. " --script " .. script, 0)
  local g = T.read(script)
  T.contains(g, "title '/world/door.door_angle'")
  T.contains(g, "title '/world/wrench.fx'")
  T.contains(g, "title '/world/base.x'")
  T.ok(not g:find("/world/arm.q1", 1, true), "the door's signals by default:\n" .. g)
  T.dca("sim --duration 0.2 --record " .. csv, 0)
  T.dca("plot " .. csv .. " --signal 'door_*' --script " .. script, 0)
  g = T.read(script)
  T.contains(g, "title 'door_angle'")
  T.ok(not g:find("'q1'", 1, true), g)
end)

-- A message port's numeric fields are signals, nested and indexed; its strings are not.
suite:case("a_message_ports_numeric_fields_are_signals", function()
  local mcap = T.tmpname(".mcap")
  local w = assert(require("dca.core").mcap_writer(mcap))
  local twist = w:channel("/main/base/Twist", "geometry_msgs/msg/Twist", "{}")
  local js = w:channel("/main/arm/JointState", "sensor_msgs/msg/JointState", "{}")
  for i = 0, 2 do
    w:write(twist, '{"value":{"linear":{"x":1,"y":0,"z":0},"angular":{"x":0,"y":0,"z":0.5}}}', i * 10000000)
    w:write(js, '{"value":{"header":{"stamp":{"sec":0,"nanosec":' .. i * 10000000 .. '},"frame_id":"base"},' ..
                '"name":["a","b"],"position":[0.1,0.2],"velocity":[],"effort":[]}}', i * 10000000)
  end
  assert(w:finish())
  local out = T.dca("plot " .. mcap .. " --list", 0, "/main/base/Twist.linear.x  3 samples",
                    "/main/base/Twist.angular.z  3 samples", "/main/arm/JointState.header.stamp.nanosec  3 samples",
                    "/main/arm/JointState.position[0]  3 samples", "/main/arm/JointState.position[1]  3 samples")
  T.ok(not out:find("frame_id", 1, true) and not out:find("JointState.name", 1, true), "strings are no signals:\n" .. out)
end)

-- A ros2 profile channel's CDR (docs/recording.md, "The ros2 profile") read as the port's JSON: a Twist's 4-byte
-- encapsulation header and six doubles.
suite:case("a_ros2_cdr_message_reads_as_its_ports_json", function()
  local core = require "dca.core"
  local cdr = "\0\1\0\0" .. string.pack("<dddddd", 1, 2, 3, 4, 5, 6.5)
  local json = core.mcap_message_json("cdr", "ros2msg", "geometry_msgs/msg/Twist", cdr)
  local v = core.json_decode(json).value
  T.eq(v.linear.x, 1.0)
  T.eq(v.linear.z, 3.0)
  T.eq(v.angular.z, 6.5)
  T.eq(core.mcap_message_json("cdr", "ros2msg", "geometry_msgs/msg/Twist", cdr:sub(1, 20)), '{"value":null}')
  T.eq(core.mcap_message_json("json", "jsonschema", "geometry_msgs/msg/Twist", cdr), nil)
  T.eq(core.mcap_message_json("cdr", "ros2msg", "no_msgs/msg/Nothing", cdr), nil)
end)

suite:case("errors_name_the_file", function()
  T.dca("plot /nonexistent.mcap", 1, "dca plot: /nonexistent.mcap: cannot open the recording")
  local bad = T.tmpfile("a,b\n1,2,3\n", ".csv")
  T.dca("plot " .. bad, 1, bad .. ": line 2: 3 numbers for 2 columns")
  -- over 1 GiB (sparse: no disk): refused by its size before a byte is read
  local huge = T.tmpname(".mcap")
  T.sh("truncate -s 3221225473 " .. huge)
  T.dca("plot " .. huge, 1, huge .. ": 3221225473 bytes: dca plot reads recordings of at most 1 GiB")
  T.dca("plot", 2, "usage: dca plot")
  T.dca("plot x.mcap --frob", 2, "dca plot: unknown option '--frob'")
end)

return suite:run(...)
