-- The sensors of a URDF world end to end (docs/robots.md, "Sensors"), on tests/sim/robots/sensor_rover.urdf:
-- `dca types --world` lists their ports; a sensor declared on a moving joint stops it with its file:line error;
-- a run records them as the world's other outputs, one MCAP channel per port; a system finds them by name.
local T = require "dca.testing"
local suite = T.suite("robot_sensors")

local dca, src = T.exe, T.src
local rover = src .. "/tests/sim/robots/sensor_rover.urdf"

suite:case("dca_types_lists_the_sensor_ports", function()
  local out, rc = T.sh(dca .. " types --world " .. rover)
  T.eq(rc, 0, out)
  for _, port in ipairs({ "sensor.wrist_ft.force", "sensor.wrist_ft.torque", "sensor.base_imu.orientation",
                          "sensor.base_imu.angular_velocity", "sensor.base_imu.linear_acceleration",
                          "sensor.odometry.pose", "sensor.odometry.twist" }) do
    T.ok(out:find("out    " .. port .. " +vector%[[34]%]"), port .. " in:\n" .. out)
  end
  T.contains(out, "sensor.wrist_ft.force                    vector[3] N, in link flange")
  local mock = T.sh(dca .. " types --world 'mock:" .. rover .. "'")
  T.contains(mock, "out    sensor.odometry.twist")
end)

suite:case("a_force_torque_sensor_on_a_moving_joint_is_a_file_line_error", function()
  local text = T.read(rover)
  local line = select(2, text:sub(1, text:find("<param name=\"joint\">flange_joint", 1, true)):gsub("\n", "")) + 1
  local broken = T.write(T.tmpname(".urdf"), (text:gsub("<param name=\"joint\">flange_joint", "<param name=\"joint\">arm_joint")))
  local out, rc = T.sh(dca .. " types --world " .. broken)
  T.ok(rc ~= 0, "a failure:\n" .. out)
  T.contains(out, broken .. ":" .. line .. ":7: ros2_control sensor 'wrist_ft': joint 'arm_joint' is revolute: a "
    .. "force_torque sensor measures across a fixed joint")
end)

-- A system that turns the base by its yaw joint, its run recorded: the sensors' ports are channels of their own.
suite:case("a_run_records_the_sensors_as_channels", function()
  local system = T.tmpfile([[
process main() {
  instantiated_processes {
    turn instof JointSetpoint("base", "base_yaw_joint", 0.5, 0.01, "velocity", 4);
  }
  internal_event_actions {
    turn
  }
}
]])
  local mcap = T.tmpname(".mcap")
  local out, rc = T.sh("timeout 120 " .. dca .. " run " .. system .. " --sim " .. rover .. " --record " .. mcap)
  T.eq(rc, 0, "exit code\n" .. out)
  T.contains(out, "main: DONE")
  T.ok(T.exists(mcap), "the recording " .. mcap)
  for _, topic in ipairs({ "/world/sensor/wrist_ft/force", "/world/sensor/base_imu/angular_velocity",
                           "/world/sensor/odometry/pose" }) do
    local n = tonumber(out:match(topic:gsub("%p", "%%%0") .. " (%d+)"))
    T.ok(n and n > 100, "channel " .. topic .. " with its messages in:\n" .. out)
  end
end)

return suite:run(...)
