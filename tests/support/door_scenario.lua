-- The door system in simulated time for the tests/scenarios/door_*.lua scenarios (each says S.backends = {"real"}):
--   local door = dofile((os.getenv("DCA_SOURCE_DIR") or ".") .. "/tests/support/door_scenario.lua")
--   local sys = door.system(S, { jammed = true })   -- door_open.dca with the door world, seed 1, and these options
--   door.up(S, sys, "the tree comes up ...")         -- the step that starts it: up, the world's time at 0
--   door.norm(v)                                     -- the Euclidean norm of a vector read from the world
local M = {}

local src = os.getenv("DCA_SOURCE_DIR") or "."

function M.system(S, opts)
  local o = { sim = "door", seed = 1 }
  for k, v in pairs(opts or {}) do o[k] = v end
  return S.system(src .. "/scripts/systems/door_open.dca", o)
end

function M.up(S, sys, name)
  S.step(name, function()
    sys:up(60)
    S.eq(sys:world_status().t, 0)
  end)
end

function M.norm(v)
  local s = 0
  for _, x in ipairs(type(v) == "table" and v or {}) do s = s + x * x end
  return math.sqrt(s)
end

return M
