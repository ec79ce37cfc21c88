-- dca.launch.reports: report hooks, the domain's part of a simulated run's summary. The hook of world W is
-- the module dca.launch.reports.W when there is one (the door world's: dca.launch.reports.door); the run
-- machinery knows no world by name (a URDF world's is dca.launch.reports.robot). A hook is a table of
--   leaves(spec)                    --> the leaf paths it will ask about at the end (before the tree stops)
--   head(status)                    --> lines that open the summary (status: the world's `status` reply)
--   tail(leaves, daemon, key, cb)   -- cb(lines) that close it (daemon: a dca.clients.daemon client)
local M = {}

local NONE = {
  leaves = function() return {} end,
  head = function() return {} end,
  tail = function(_, _, _, cb) cb({}) end,
}

--- The report hook of world `name` (a hook that adds nothing when it has none). A URDF world (ROBOT.urdf,
--- mock:ROBOT.urdf) has the robot's: dca.launch.reports.robot.
function M.for_world(name)
  if type(name) == "string" and name:find("%.urdf") then return require("dca.launch.reports.robot") end
  local mod = "dca.launch.reports." .. tostring(name)
  if type(name) ~= "string" or not name:match("^[%w_]+$") or not package.searchpath(mod, package.path) then
    return NONE
  end
  return require(mod)
end

return M
