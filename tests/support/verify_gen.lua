-- Random task expressions for dca.verify's tests and benchmark: expression text over leaves L1..Ln (each name
-- once, so the static rules always hold), what each leaf can do (a manifest's `ends`), and properties.
--   local gen = dofile(T.src .. "/tests/support/verify_gen.lua")
--   local text, ends, props_text = gen.expression(rnd, leaves, first)   -- rnd(n) -> 1..n
local M = {}

local OPS = { ",", ";", "#", ":", ":;" }
local ENDS = { "never", "done", "aborted", "done or aborted", false }

--- Expression text over `count` leaves named L<first>..; --> text, is_composite
function M.tree(rnd, first, count)
  if count == 1 then return "L" .. first, false end
  local op = OPS[rnd(#OPS)]
  local parts = (op == ":" or op == ":;") and 2 or math.min(count, 1 + rnd(3))
  local size, out, at = count // parts, {}, first
  for p = 1, parts do
    local c = (p == parts) and (first + count - at) or size
    local s, composite = M.tree(rnd, at, c)
    out[p] = composite and ("(" .. s .. ")") or s
    at = at + c
  end
  return table.concat(out, " " .. op .. " "), true
end

--- A random expression of `count` leaves, each leaf's ends (nil: undeclared), and properties' text.
function M.expression(rnd, count, first)
  first = first or 1
  local text = M.tree(rnd, first, count)
  local ends = {}
  for i = first, first + count - 1 do ends["L" .. i] = ENDS[rnd(#ENDS)] or nil end
  local function name() return "L" .. (first + rnd(count) - 1) end
  local patterns = {
    function() return name() .. " never starts before " .. name() .. " is done;" end,
    function() return name() .. " always ends before " .. name() .. " starts;" end,
    function() return name() .. " runs while any step runs;" end,
    function() return name() .. " runs while " .. name() .. " runs;" end,
    function() return "never (" .. name() .. " and " .. name() .. " running);" end,
  }
  local props = {}
  for _ = 1, rnd(3) - 1 do props[#props + 1] = patterns[rnd(#patterns)]() end
  return text, ends, table.concat(props, " ")
end

return M
