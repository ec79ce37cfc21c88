-- dca.worlds: the Lua side of the world plug-ins (docs/worlds.md). A world's descriptor is all the run machinery,
-- the world client and the monitor know of a world: the C++ plug-in gives its signals and checks its options
-- (core.world_signals), and the file worlds/NAME/world.lua (in core.worlds_dir) gives the rest:
--
--   return {
--     report = { leaves = fn(spec), head = fn(status), tail = fn(leaves, daemon, key, cb) },  -- the run's summary
--     topics = { { topic = "/world/x", fields = { "a", "b" } },            -- live plots from the world's status:
--                { topic = "/world/y", fields = { "x", "y" }, array = "k" }, -- fields a, b; or status.k's items;
--                { topic = "/world/z", array = "n" },                        -- or all of status.n's items, as
--                                                                           -- value[0], value[1], ...
--                { topic = "/world/w", value = "m", units = "rad" } }        -- or status.m as value[0]; units:
--                                                                           -- the world signal's (manifest)
--     -- (a topic named as one of the world's signals is its live topic and recorded channel: the status is
--     -- published there only when no tap feeds it, e.g. in a monitor attached to a running system)
--     plot = { "/world/x.*", ... },   -- the signals `dca plot` draws by default (patterns as its --signal's)
--   }
--
-- Both parts are optional. A URDF world (ROBOT.urdf, mock:ROBOT.urdf) has the generic robot report and, when it
-- has command inputs, the safety layer's counts per input (in input order, as its outputs safety.clamps and
-- safety.stale and their recorded channels of the same names: docs/robots.md) as /world/safety/clamps and
-- /world/safety/stale.
--
--   local worlds = require "dca.worlds"
--   worlds.descriptor(spec)           --> the descriptor of world `spec` (nil: the default world), never nil
--   worlds.resolve(spec)              --> the world's spec (nil: the default world's name), or spec as given
--   worlds.check(spec, opts)          --> true | nil, error (an unknown world, a bad option: core.world_signals)
local M = {}

local type, tostring, pcall = type, tostring, pcall

local NONE_REPORT = {
  leaves = function() return {} end,
  head = function() return {} end,
  tail = function(_, _, _, cb) cb({}) end,
}

local function core_or_nil()
  local ok, core = pcall(require, "dca.core")
  return ok and type(core) == "table" and core or nil
end

--- Whether `spec` names a URDF world.
function M.is_robot(spec)
  return type(spec) == "string" and spec:find("%.urdf") ~= nil
end

--- The world `spec` names: nil is the default world's name (from the plug-ins), anything else as given.
function M.resolve(spec)
  if spec ~= nil then return spec end
  local core = core_or_nil()
  local s = core and type(core.world_signals) == "function" and core.world_signals() or nil
  return s and s.world or nil
end

--- Checks world `spec` and its options (a list of "KEY=VALUE"): true, or nil and why (the world's own words).
function M.check(spec, opts)
  local core = core_or_nil()
  if not (core and type(core.world_signals) == "function") then return true end
  local s, err = core.world_signals(spec, opts or {})
  if s == nil and err then return nil, err end
  return true
end

local cache = {}

-- The descriptor file of world `name` in the worlds' folder: its table, or nil.
local function load_file(name)
  local core = core_or_nil()
  local dir = os.getenv("DCA_WORLDS_DIR") or (core and core.worlds_dir)
  if not (dir and type(name) == "string" and name:match("^[%w_]+$")) then return nil end
  local path = dir .. "/" .. name .. "/world.lua"
  local f = io.open(path, "r")
  if not f then return nil end
  f:close()
  local chunk, err = loadfile(path, "t")
  if not chunk then error(path .. ": " .. tostring(err), 0) end
  local d = chunk()
  if type(d) ~= "table" then error(path .. ": a world's descriptor returns a table", 0) end
  return d
end

--- The descriptor of world `spec` (see the header), with its report hook and topics always present.
function M.descriptor(spec)
  spec = M.resolve(spec)
  local key = tostring(spec)
  if cache[key] then return cache[key] end
  local d
  if M.is_robot(spec) then
    d = { report = require("dca.launch.robot_report"),
          topics = { { topic = "/world/safety/clamps", array = "safety_clamps" },
                     { topic = "/world/safety/stale", array = "safety_stale" } } }
  else d = load_file(spec) or {} end
  d.report = d.report or NONE_REPORT
  d.topics = d.topics or {}
  cache[key] = d
  return d
end

return M
