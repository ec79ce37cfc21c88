-- The door system in simulated time for the worlds/door/tests/scenarios/door_*.lua scenarios (each says S.backends = {"real"}):
--   local door = dofile((os.getenv("DCA_SOURCE_DIR") or ".") .. "/tests/support/door_scenario.lua")
--   local sys = door.system(S, { world_opts = { "jammed" } })  -- door_open.dca, the door world, seed 1, these options
--   door.up(S, sys, "the tree comes up ...")         -- the step that starts it: up, the world's time at 0
--   door.variant("DoorOpenSystem", "supervision { ... }")  -- door_open.dca with that section: file, options;
--                                                    --   T.cleanup() (dca.testing) once it is up removes the file
--   local at = door.held(S, sys, 2.0)                -- the step that runs it until time is held at 2 s with
--                                                    --   VisualServoing running: at.t (time held), at.pid (its pid)
--   door.opens(S, sys)                               -- the last step: time flows, DONE, the door at >= 70 degrees
--   door.norm(v)                                     -- the Euclidean norm of a vector read from the world
local T = require "dca.testing"
local M = {}

local src = os.getenv("DCA_SOURCE_DIR") or "."

function M.system(S, opts)
  local o = { sim = "door", seed = 1 }
  for k, v in pairs(opts or {}) do o[k] = v end
  local file = o.file or src .. "/worlds/door/systems/door_open.dca"
  o.file = nil
  return S.system(file, o)
end

-- door_open.dca with `section` (a `supervision { }` section) in process `proc`, after its host { } line, written
-- to a temporary file (the package is found on the search path, the defaults come from door_open.config).
-- --> the file, the options for M.system; T.cleanup() removes the file once the system is up
function M.variant(proc, section)
  local f = assert(io.open(src .. "/worlds/door/systems/door_open.dca")) local text = f:read("a") f:close()
  local n
  text, n = text:gsub("(\nprocess " .. proc .. "%b()%s*{%s*host%s*%b{})", "%1\n  " .. section)
  assert(n == 1, "door_open.dca: no process " .. proc .. " with a host { } line")
  local file = T.tmpfile(text)
  return file, { file = file, config = src .. "/worlds/door/systems/door_open.config" }
end

function M.up(S, sys, name)
  S.step(name, function()
    sys:up(60)
    S.eq(sys:world_status().t, 0)
  end)
end

M.VS = "main.dooropensyst.visualserv"

function M.held(S, sys, t)
  local at = {}
  S.step(string.format("VisualServoing runs and the base moves (time held at %g s)", t), function()
    sys:run()
    sys:wait_state(M.VS, "running", 30)
    at.t = sys:world_hold_at(t, 60)
    at.pid = sys:pid(M.VS)
    local v = sys:world_read("base.cmd_vel")
    -- (a failure says why a node left the clock, if one did: a flake once dropped puma at 20 ms)
    S.ok(M.norm(v) > 1e-4, "base.cmd_vel " .. S.show(v) .. ", the clock's dropped subscribers "
      .. S.show(sys:world_status().dropped))
  end)
  return at
end

function M.opens(S, sys)
  S.step("time flows on: the door opens to at least 70 degrees and the task ends DONE", function()
    sys:world_go()
    local out = sys:wait_outcome(300)
    S.eq(out.type, "done", "outcome " .. S.show(out))
    local angle = math.deg(sys:world_status().door_angle)
    S.ok(angle >= 70, "door angle " .. tostring(angle))
  end)
end

function M.norm(v)
  local s = 0
  for _, x in ipairs(type(v) == "table" and v or {}) do s = s + x * x end
  return math.sqrt(s)
end

return M
