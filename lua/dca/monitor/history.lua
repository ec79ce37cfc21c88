-- dca.monitor.history: a signal's samples from the start of a run, bounded and decimated evenly (pure: no I/O).
-- The monitor's server keeps one per topic it publishes itself (the world's status: /world/door, ...), so a page
-- that picks such a signal late gets it from the start.
--
--   local history = require "dca.monitor.history"
--   local h = history.new(max)   -- at most `max` rows (default M.MAX), max >= 2
--   h:add(t, values)             -- one sample: kept when it falls on the stride (every `h.stride`-th sample)
--   h:rows()                     --> { { t, v1, v2, ... }, ... } in time order (the same table: do not change it)
-- When the rows reach `max`, every other row goes (the first stays) and the stride doubles: the rows always span
-- the whole run at one even spacing, at most `max` of them, whatever the run's length.
local M = {}

--- Rows kept per topic.
M.MAX = 2000

local H = {}
H.__index = H

function M.new(max)
  max = math.max(2, math.tointeger(max) or M.MAX)
  return setmetatable({ max = max, list = {}, stride = 1, seen = 0 }, H)
end

function H:add(t, values)
  local n = self.seen
  self.seen = n + 1
  if n % self.stride ~= 0 then return end
  local row = { t }
  for k, v in ipairs(values) do row[k + 1] = v end
  local list = self.list
  list[#list + 1] = row
  if #list >= self.max then
    local kept = {}
    for i = 1, #list, 2 do kept[#kept + 1] = list[i] end
    self.list, self.stride = kept, self.stride * 2
  end
end

function H:rows() return self.list end

return M
