-- dca.clients.world: the argv of the world process carries exactly the options asked for.
local T = require "dca.testing"
local suite = T.suite("world")

suite:case("world_argv_carries_the_seed_and_the_worlds_own_options", function()
  local world = require "dca.clients.world"
  local argv = world.argv({ daemon = "127.0.0.1:1", host = "h", world = "door", seed = 3,
                            world_opts = { "door_width=0.9", "jammed" } })
  T.eq(argv, { "dca", "sim", "--serve", "--daemon", "127.0.0.1:1", "--host", "h", "--world", "door",
               "--seed", "3", "--world-opt", "door_width=0.9", "--world-opt", "jammed" })
  argv = world.argv({ daemon = "127.0.0.1:1", host = "h", world = "door" })
  for _, a in ipairs(argv) do T.ok(a ~= "--world-opt", "no --world-opt unless asked") end
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
