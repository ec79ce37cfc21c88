-- dca.verify.zone: when the running timers can end (docs/verify.md, "Time"). A timer is a leaf that ends by
-- itself after a constant number of seconds (Timer, Deadline); every other leaf's event may come at any time.
-- A zone is the set of values the running timers' clocks (the seconds since each started) can have now, as a
-- difference-bound matrix (as in timed automata): D[i][j] bounds x_i - x_j from above, index 0 being the
-- constant 0. Time passes between steps up to the first timer's end (x_i <= d_i); a timer's own end needs
-- x_i = d_i. So a timer started after another ends after it when it is not shorter, across steps too, and one
-- started when another ended knows how long that one ran.
--
--   local zone = require "dca.verify.zone"
--   local z = zone.step(nil, timed, nil, false, {}, running)    -- the start: running timers at 0, time passed
--   zone.may_end(z, timed, l)   --> whether timer l can end by itself now
--   z = zone.step(z, timed, l, own, before, after)   -- after an event of leaf l (own: timer l's own end)
--   zone.key(z)                 --> its text, for the state's key
-- timed[id] = the seconds of timer occurrence id; before, after: the running occurrences around the step.
local M = {}

local ipairs, concat, min, huge = ipairs, table.concat, math.min, math.huge

-- Floyd-Warshall: the tightest bounds (the canonical form).
local function close(D, n)
  for k = 0, n do
    local Dk = D[k]
    for i = 0, n do
      local Di, dik = D[i], D[i][k]
      if dik < huge then
        for j = 0, n do
          local v = dik + Dk[j]
          if v < Di[j] then Di[j] = v end
        end
      end
    end
  end
end

-- The index of occurrence l in z (nil: no clock).
local function index(z, l)
  for i, id in ipairs(z.ids) do if id == l then return i end end
  return nil
end

function M.may_end(z, timed, l)
  local i = z and index(z, l)
  if not i then return true end
  return z.D[i][0] >= timed[l]
end

--- The zone after an event of leaf l (own: timer l's own end, at x_l = d_l): the ended timers' clocks
--- dropped, the started ones at 0, then time passing up to the first timer's end.
function M.step(z, timed, l, own, _, after)
  z = z or { ids = {}, D = { [0] = { [0] = 0 } } }
  local D = z.D
  local il = own and index(z, l)
  if il then
    D = {}
    for i = 0, #z.ids do D[i] = {} for j = 0, #z.ids do D[i][j] = z.D[i][j] end end
    D[0][il] = min(D[0][il], -timed[l])
    close(D, #z.ids)
  end
  local ids = {}
  for _, id in ipairs(after) do if timed[id] then ids[#ids + 1] = id end end
  table.sort(ids)  -- (after is in start order; the key wants one order)
  local from = {}
  for n, id in ipairs(ids) do
    local k = index(z, id)
    from[n] = (k and k ~= il) and k or 0  -- a clock started now equals the constant 0
  end
  local N = { [0] = { [0] = 0 } }
  for i = 0, #ids do
    N[i] = N[i] or {}
    for j = 0, #ids do
      local a, b = i == 0 and 0 or from[i], j == 0 and 0 or from[j]
      N[i][j] = D[a][b]
    end
  end
  for i, id in ipairs(ids) do N[i][0] = timed[id] end  -- time passes, up to each timer's end
  close(N, #ids)
  return { ids = ids, D = N }
end

function M.key(z)
  local parts = { concat(z.ids, ",") }
  for i = 0, #z.ids do
    local row = {}
    for j = 0, #z.ids do row[#row + 1] = z.D[i][j] == huge and "-" or z.D[i][j] end
    parts[#parts + 1] = concat(row, " ")
  end
  return concat(parts, ";")
end

return M
