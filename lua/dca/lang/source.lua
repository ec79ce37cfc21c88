-- dca.lang.source: positions in source text and the error format every dca language tool uses:
--   file:line:col: message
--   <the source line>
--   <a caret under the column>
local M = {}

local sfind, ssub, sbyte, sformat = string.find, string.sub, string.byte, string.format

--- A position index over `text`: idx:at(pos) -> line, col (1-based; col counts bytes).
function M.index(text)
  local starts, n = { 1 }, 1
  local i = sfind(text, "\n", 1, true)
  while i do
    n = n + 1
    starts[n] = i + 1
    i = sfind(text, "\n", i + 1, true)
  end
  local idx = { text = text, starts = starts }
  local last = 1   -- the line of the previous lookup: lookups mostly move forward a little
  function idx.at(_, pos)
    local l = last
    if starts[l] <= pos then
      local steps = 0
      while l < n and starts[l + 1] <= pos and steps < 8 do l, steps = l + 1, steps + 1 end
      if l == n or starts[l + 1] > pos then
        last = l
        return l, pos - starts[l] + 1
      end
    end
    local lo, hi = 1, n
    while lo < hi do
      local mid = (lo + hi + 1) // 2
      if starts[mid] <= pos then lo = mid else hi = mid - 1 end
    end
    last = lo
    return lo, pos - starts[lo] + 1
  end
  --- t[lk or "line"], t[ck or "col"] = the line and column of pos (one call, for building ASTs).
  function idx.set(t, pos, lk, ck)
    local l = last
    if starts[l] > pos then l = 1 end
    local nxt = starts[l + 1]
    while nxt and nxt <= pos do
      l = l + 1
      nxt = starts[l + 1]
      if l - last > 64 then break end
    end
    if nxt and nxt <= pos then l = idx:at(pos) end
    last = l
    t[lk or "line"], t[ck or "col"] = l, pos - starts[l] + 1
  end
  function idx.line_text(_, line)
    local s = starts[line]
    if not s then return "" end
    local e = starts[line + 1]
    local l = e and ssub(text, s, e - 2) or ssub(text, s)
    return (l:gsub("\r$", ""))
  end
  return idx
end

--- The caret line for column `col` of `line_text` (tabs kept so that the caret lines up).
function M.caret(line_text, col)
  local prefix = ssub(line_text, 1, col - 1):gsub("[^\t]", " ")
  return prefix .. "^"
end

-- Bounds on what an error shows: the source line a window around the column, the message its first bytes (a
-- 50 MB one-line identifier gave a 157 MB error).
M.SHOWN_LINE, M.SHOWN_MESSAGE = 160, 2000

--- `text` cut to `max` bytes, saying how many more there were.
function M.clip(text, max)
  if #text <= max then return text end
  return sformat("%s... (%d bytes more)", ssub(text, 1, max), #text - max)
end

--- "file:line:col: message\n<line>\n<caret>" (no trailing newline); a long line is shown around the column,
--- a long message clipped.
function M.format(file, idx, line, col, message)
  local lt = idx:line_text(line)
  if #lt > M.SHOWN_LINE then
    local from = math.max(1, col - M.SHOWN_LINE // 2)
    local cut = ssub(lt, from, from + M.SHOWN_LINE - 1)
    lt, col = (from > 1 and "..." or "") .. cut .. (from + M.SHOWN_LINE - 1 < #lt and "..." or ""),
      col - from + 1 + (from > 1 and 3 or 0)
  end
  return sformat("%s:%d:%d: %s\n%s\n%s", file, line, col, M.clip(message, M.SHOWN_MESSAGE), lt, M.caret(lt, col))
end

--- The edit distance of two short strings (insertions, deletions, substitutions and transpositions of
--- neighbours each count 1), for "did you mean".
function M.distance(a, b)
  local la, lb = #a, #b
  if la == 0 then return lb end
  if lb == 0 then return la end
  local d = {}
  for i = 0, la do d[i] = { [0] = i } end
  for j = 0, lb do d[0][j] = j end
  for i = 1, la do
    local ca, row, up = sbyte(a, i), d[i], d[i - 1]
    for j = 1, lb do
      local cb = sbyte(b, j)
      local cost = (ca == cb) and 0 or 1
      local v = up[j] + 1
      if row[j - 1] + 1 < v then v = row[j - 1] + 1 end
      if up[j - 1] + cost < v then v = up[j - 1] + cost end
      if i > 1 and j > 1 and ca == sbyte(b, j - 1) and sbyte(a, i - 1) == cb and d[i - 2][j - 2] + 1 < v then
        v = d[i - 2][j - 2] + 1
      end
      row[j] = v
    end
  end
  return d[la][lb]
end

--- The candidate closest to `word` (case-insensitive distance at most (#word + 1) // 3), or nil.
--- `candidates` is a list of strings.
function M.closest(word, candidates)
  if #word > 64 then return nil end  -- no name is that long: no guess (and no quadratic distance)
  local best, best_d
  local lw = word:lower()
  local limit = (#word + 1) // 3
  for _, c in ipairs(candidates) do
    if c ~= word then
      local d = M.distance(lw, c:lower())
      if d <= limit and (not best_d or d < best_d or (d == best_d and c < best)) then best, best_d = c, d end
    end
  end
  return best
end

return M
