-- dca.launch.robot_report: a URDF world's part of a simulated run's summary (`dca run --sim ROBOT.urdf`,
-- docs/robots.md): the joints' positions at the end, what the safety layer at the ports did (commands clamped,
-- watchdogs tripped, efforts saturated) and the warnings of loading the robot (a mesh not found).
-- A report hook (dca.worlds): leaves(spec), head(status), tail(leaves, daemon, key, cb).
local M = {}

local ipairs, pairs, tostring, sformat, tonumber, sort = ipairs, pairs, tostring, string.format, tonumber, table.sort

function M.leaves() return {} end

--- The lines that open the summary, from the world's status.
function M.head(status)
  local lines = {}
  local names = {}
  for name in pairs(status.joint_position or {}) do names[#names + 1] = name end
  sort(names)
  local parts = {}
  for _, name in ipairs(names) do
    parts[#parts + 1] = sformat("%s %.4f", name, tonumber(status.joint_position[name]) or 0)
  end
  if #parts > 0 then lines[1] = "joints at the end: " .. table.concat(parts, ", ") end
  for _, l in ipairs(status.world_summary or {}) do lines[#lines + 1] = tostring(l) end
  for _, w in ipairs(status.warnings or {}) do lines[#lines + 1] = "warning: " .. tostring(w) end
  return lines
end

function M.tail(_, _, _, cb) cb({}) end

return M
