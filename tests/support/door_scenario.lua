-- The door system in simulated time for the tests/scenarios/door_*.lua scenarios (each says S.backends = {"real"}):
--   local door = dofile((os.getenv("DCA_SOURCE_DIR") or ".") .. "/tests/support/door_scenario.lua")
--   local sys = door.system(S, { jammed = true })   -- door_open.dca with the door world, seed 1, and these options
--   door.up(S, sys, "the tree comes up ...")         -- the step that starts it: up, the world's time at 0
--   door.variant("DoorOpenSystem", "supervision { ... }")  -- door_open.dca with that section: file, options
--   door.norm(v)                                     -- the Euclidean norm of a vector read from the world
local M = {}

local src = os.getenv("DCA_SOURCE_DIR") or "."

function M.system(S, opts)
  local o = { sim = "door", seed = 1 }
  for k, v in pairs(opts or {}) do o[k] = v end
  local file = o.file or src .. "/scripts/systems/door_open.dca"
  o.file = nil
  return S.system(file, o)
end

-- door_open.dca with `section` (a `supervision { }` section) in process `proc`, after its host { } line, written
-- to a temporary file (the package is found on the search path, the defaults come from door_open.config).
-- --> the file, the options for M.system; remove the file once the system is up
function M.variant(proc, section)
  local f = assert(io.open(src .. "/scripts/systems/door_open.dca")) local text = f:read("a") f:close()
  local n
  text, n = text:gsub("(\nprocess " .. proc .. "%b()%s*{%s*host%s*%b{})", "%1\n  " .. section)
  assert(n == 1, "door_open.dca: no process " .. proc .. " with a host { } line")
  local file = os.tmpname() .. ".dca"
  f = assert(io.open(file, "w")) f:write(text) f:close()
  return file, { file = file, config = src .. "/scripts/systems/door_open.config" }
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
