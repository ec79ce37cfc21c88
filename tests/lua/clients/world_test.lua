-- dca.clients.world: the argv of the world process carries exactly the options asked for.
local T = require "dca.testing"
local suite = T.suite("world")

suite:case("world_argv_carries_seed_width_and_the_jam", function()
  local world = require "dca.clients.world"
  local argv = world.argv({ daemon = "127.0.0.1:1", host = "h", world = "door", seed = 3, door_width = 0.9, jammed = true })
  T.eq(argv, { "dca", "sim", "--serve", "--daemon", "127.0.0.1:1", "--host", "h", "--world", "door",
               "--seed", "3", "--door-width", "0.9", "--jammed" })
  argv = world.argv({ daemon = "127.0.0.1:1", host = "h", world = "door" })
  for _, a in ipairs(argv) do T.ok(a ~= "--jammed", "no --jammed unless asked") end
end)

suite:case("the_world_argv_carries_realtime_only_when_asked", function()
  local world = require "dca.clients.world"
  local argv = world.argv({ daemon = "127.0.0.1:1", host = "h", world = "door", realtime = true })
  T.eq(argv, { "dca", "sim", "--serve", "--daemon", "127.0.0.1:1", "--host", "h", "--world", "door", "--realtime" })
  for _, a in ipairs(world.argv({ daemon = "127.0.0.1:1", host = "h", world = "door" })) do
    T.ok(a ~= "--realtime", "no --realtime unless asked")
  end
end)

return suite:run(...)
