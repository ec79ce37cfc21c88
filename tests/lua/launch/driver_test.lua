-- dca.launch.driver: `dca run FILE --driver 'TYPE(HOST, ARGS...)'` reads the driver as an instance of a .dca file
-- (checked as one, errors at --driver:1:COL), holds the leaves' device ports to its ports, and starts it as
-- `dca node --name world` (docs/drivers.md). The run through a driver over a pty is
-- install.pty_driver_runs_the_ur10_in_wall_clock_time (tests/install/pty_driver_test.cmake).
local T = require "dca.testing"
local driver = require "dca.launch.driver"
local suite = T.suite("driver")

local system = T.src .. "/worlds/ur10/ur10_setpoint.dca"

suite:case("the_driver_is_read_as_an_instance_and_its_ports_are_the_signals", function()
  local d = assert(driver.read('Gain("arm", 2)', system))
  T.eq(d.leaf.type, "Gain")
  T.eq(d.leaf.host, "arm")
  T.eq(d.leaf.args, { 2 })
  T.eq(d.dir, T.src .. "/worlds/ur10")
  T.eq(d.signals.inputs.In.name, "In")
  T.eq(d.signals.outputs.Out.name, "Out")
  T.eq(driver.argv(d, "127.0.0.1:7000", "/k"),
    { "dca", "node", "--type", "Gain", "--name", "world", "--daemon", "127.0.0.1:7000", "--key", "/k", "--", "2" })
end)

suite:case("a_bad_driver_is_an_error_at_its_column", function()
  local d, err = driver.read('Gain("arm", "x")', system)
  T.eq(d, nil)
  T.contains(err, '--driver Gain("arm", "x"):\n--driver:1:13: ')
  T.contains(err, "'k'")
  _, err = driver.read('nopkg.Nope("arm")', system)
  T.contains(err, "--driver:1:1: ")
  T.contains(err, "nopkg")
  T.ok(not err:find(T.src .. "/worlds/ur10/--driver", 1, true), "the pseudo-file is never named: " .. err)
end)

suite:case("the_device_ports_are_held_to_the_drivers_ports", function()
  T.dca("run " .. system .. " --driver 'Gain(\"arm\", 2)'", 2,
    "the world has no sensor 'joint.elbow_joint.position'", "the world has no command 'joint.elbow_joint.position_command'")
  T.dca("run " .. system .. " --driver 'Gain(\"arm\", 2)' --sim mock:" .. T.src .. "/worlds/ur10/ur10.urdf", 2,
    "--driver and --sim exclude each other")
end)

return suite:run(...)
