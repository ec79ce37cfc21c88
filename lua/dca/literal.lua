-- dca.literal: a reader of Lua literals that never runs anything. Configuration defaults (FILE.config) and
-- `--set KEY=VALUE` values are data, read here, never given to load().
--
--   local literal = require "dca.literal"
--   local v, err, col = literal.read('{1, 2.5, side = "right"}')  -- the value, or nil, the reason, its column
--   local v, stop = literal.prefix(text, init)   -- the literal at text[init..]; stop: the first byte after it
--                                                -- (and after the blanks and `--` comments that follow it)
--
-- The grammar, a subset of Lua's expressions in which nothing is named, called, indexed or computed:
--   value  = number | string | true | false | table                  (nil is not a value)
--   number = ["-"] numeral, a decimal (75, -0.45, .5, 3., 1e-3, 2E+10) or hexadecimal (0xff, 0x1p4, 0xA.8)
--            numeral converted as Lua converts it (an integer when it is one and fits, else a float); no "+",
--            no inf or nan: a numeral past the largest double (1e999) or a hexadecimal integer past 64 bits is
--            an error, not inf or a wrapped-around integer
--   string = "..." or '...' with Lua's escapes (\a \b \f \n \r \t \v \\ \" \' \<line break> \z \xXX \ddd
--            \u{XXX}; a line break needs its backslash), or a long bracket [[...]], [==[...]==]
--   table  = "{" [field {("," | ";") field} ["," | ";"]] "}"
--   field  = "[" key "]" "=" value | name "=" value | value
--            (key: a number, string or boolean; name: a Lua name that is not a reserved word)
-- Blanks and `--` comments (to the end of the line) may stand between tokens.
-- Bounds: at most MAX_LENGTH bytes of text and MAX_DEPTH nested tables, beyond them an error (the depth bound
-- keeps the recursion shallow). Neither read nor prefix ever raises, whatever the input; errors give the
-- column (byte offset + 1 in text) of the offending character.
local M = { MAX_LENGTH = 1 << 20, MAX_DEPTH = 32 }

local type, tonumber, tostring, pcall, error, pairs = type, tonumber, tostring, pcall, error, pairs
local sfind, ssub, sbyte, schar, smatch, sformat = string.find, string.sub, string.byte, string.char,
  string.match, string.format
local concat, utf8char = table.concat, utf8.char

local RESERVED = {}
for w in ([[and break do else elseif end false for function goto if in local nil not or repeat return then
            true until while]]):gmatch("%a+") do RESERVED[w] = true end

local ESCAPES = { a = "\a", b = "\b", f = "\f", n = "\n", r = "\r", t = "\t", v = "\v", ["\\"] = "\\",
                  ['"'] = '"', ["'"] = "'" }
local SPECIAL = { ['"'] = '[\\\r\n"]', ["'"] = "[\\\r\n']" }
local EXPECTED = 'a number, a "string", true, false or a {table}'

local function fail(pos, fmt, ...) error({ msg = sformat(fmt, ...), pos = pos }, 0) end

--- What is at pos, for messages.
local function shown(s, pos)
  if pos > #s then return "the end of the text" end
  local c = ssub(s, pos, pos)
  if smatch(c, "[%c\128-\255]") then return sformat("byte \\%d", sbyte(c)) end
  return "'" .. c .. "'"
end

--- The position of the next token: past blanks and `--` comments.
local function skip(s, pos)
  while true do
    pos = sfind(s, "[^ \t\r\n\f\v]", pos) or #s + 1
    if ssub(s, pos, pos + 1) ~= "--" then return pos end
    pos = sfind(s, "\n", pos, true) or #s + 1
  end
end

--- The number at start (a '-' or a numeral) and the position after it.
local function number(s, start)
  local pos = start
  if ssub(s, pos, pos) == "-" then pos = skip(s, pos + 1) end
  local tok = smatch(s, "^0[xX][%x%.]*", pos)
  if tok then tok = tok .. (smatch(s, "^[pP][%+%-]?%d*", pos + #tok) or "")
  else
    tok = smatch(s, "^[%d%.]*", pos)
    tok = tok .. (smatch(s, "^[eE][%+%-]?%d*", pos + #tok) or "")
  end
  local stop = pos + #tok
  local v = tok ~= "" and not smatch(s, "^[%w_%.]", stop) and tonumber(tok)
  if not v then
    fail(start, "malformed number near '%s'", ssub(s, start, (sfind(s, "[^%w_%.%-%+]", start) or #s + 1) - 1))
  end
  -- out of range: a float past the largest double (Lua reads it as inf), or a hexadecimal integer past 64 bits
  -- (Lua wraps it around: 0x7fffffffffffffffff would be -1)
  if v == math.huge or v ~= v then fail(start, "number out of range: %s", ssub(s, start, stop - 1)) end
  local hex = smatch(tok, "^0[xX]0*(%x*)$")
  if hex and (#hex > 16 or (#hex == 16 and tonumber(ssub(hex, 1, 1), 16) > 7)) then
    fail(start, "integer out of range (past 0x7fffffffffffffff): %s", ssub(s, start, stop - 1))
  end
  if pos ~= start then v = -v end
  return v, stop
end

--- The escape at s[j] (a backslash) of a quoted string: its text and the position after it.
local function escape(s, j, open)
  local e = ssub(s, j + 1, j + 1)
  if ESCAPES[e] then return ESCAPES[e], j + 2 end
  if e == "\n" or e == "\r" then  -- a line break (\n, \r, \r\n or \n\r) continues the string
    local pair = ssub(s, j + 1, j + 2)
    return "\n", j + ((pair == "\r\n" or pair == "\n\r") and 3 or 2)
  end
  if e == "z" then return "", sfind(s, "[^ \t\r\n\f\v]", j + 2) or #s + 1 end
  if e == "x" then
    local h = smatch(s, "^%x%x", j + 2)
    if not h then fail(j, "hexadecimal digits expected after '\\x'") end
    return schar(tonumber(h, 16)), j + 4
  end
  local d = smatch(s, "^%d%d?%d?", j + 1)
  if d then
    if tonumber(d) > 255 then fail(j, "decimal escape '\\%s' too large", d) end
    return schar(tonumber(d)), j + 1 + #d
  end
  if e == "u" then
    local h = smatch(s, "^{(%x+)}", j + 2)
    if not h or #h > 8 or tonumber(h, 16) >= 0x80000000 then fail(j, "malformed '\\u{XXX}' escape") end
    return utf8char(tonumber(h, 16)), j + 4 + #h
  end
  if e == "" then fail(open, "unfinished string") end
  fail(j, "invalid escape sequence '\\%s'", e)
end

--- The quoted string opening at s[open] and the position after its closing quote.
local function quoted(s, open)
  local q, parts, i = ssub(s, open, open), {}, open + 1
  while true do
    local j = sfind(s, SPECIAL[q], i)
    if not j then fail(open, "unfinished string: no closing %s", q) end
    parts[#parts + 1] = ssub(s, i, j - 1)
    local c = ssub(s, j, j)
    if c == q then return concat(parts), j + 1 end
    if c ~= "\\" then fail(j, "unfinished string: a line break before the closing %s", q) end
    parts[#parts + 1], i = escape(s, j, open)
  end
end

--- The long-bracket string opening at s[open] ([[ or [==[) and the position after its closing bracket.
local function long_string(s, open)
  local eq = smatch(s, "^%[(=*)%[", open)
  local first, close = open + #eq + 2, "]" .. eq .. "]"
  local j = sfind(s, close, first, true)
  if not j then fail(open, "unfinished long string: no closing %s", close) end
  local body = ssub(s, first, j - 1):gsub("\r\n", "\n"):gsub("\n\r", "\n"):gsub("\r", "\n")
  return (body:gsub("^\n", "")), j + #close
end

local value

--- The position after the character c expected at the next token (and after the blanks that follow it).
local function expect(s, pos, c, where)
  pos = skip(s, pos)
  if ssub(s, pos, pos) ~= c then fail(pos, "expected '%s' %s, found %s", c, where, shown(s, pos)) end
  return skip(s, pos + 1)
end

--- One field of a table at pos: its key (nil for the next positional one), its value and the position after.
local function field(s, pos, depth)
  if ssub(s, pos, pos) == "[" and not smatch(s, "^%[=*%[", pos) then
    local kpos = skip(s, pos + 1)
    local k, after = value(s, kpos, depth)
    if type(k) == "table" then fail(kpos, "a table key must be a number, a string or a boolean") end
    pos = expect(s, expect(s, after, "]", "after a [key]"), "=", "after a [key]")
    local v, stop = value(s, pos, depth)
    return k, v, stop
  end
  local name = smatch(s, "^[%a_][%w_]*", pos)
  if name and not RESERVED[name] then
    local after = skip(s, pos + #name)
    if ssub(s, after, after) == "=" and ssub(s, after + 1, after + 1) ~= "=" then
      local v, stop = value(s, skip(s, after + 1), depth)
      return name, v, stop
    end
  end
  return nil, value(s, pos, depth)
end

--- The table opening at s[open] ({) and the position after its closing brace; depth: its nesting.
local function table_value(s, open, depth)
  if depth > M.MAX_DEPTH then fail(open, "tables nested deeper than %d", M.MAX_DEPTH) end
  local t, n, pos = {}, 0, skip(s, open + 1)
  while ssub(s, pos, pos) ~= "}" do
    local k, v, stop = field(s, pos, depth + 1)
    if k == nil then n = n + 1 k = n end
    t[k] = v
    pos = skip(s, stop)
    local sep = ssub(s, pos, pos)
    if sep == "," or sep == ";" then pos = skip(s, pos + 1)
    elseif sep ~= "}" then fail(pos, "expected ',' or '}' in the table opened at column %d, found %s", open,
                                shown(s, pos)) end
  end
  return t, pos + 1
end

--- The value at pos (a token's start) and the position after it.
function value(s, pos, depth)
  local c = ssub(s, pos, pos)
  if c == '"' or c == "'" then return quoted(s, pos) end
  if c == "{" then return table_value(s, pos, depth) end
  if smatch(s, "^%[=*%[", pos) then return long_string(s, pos) end
  if smatch(s, "^[%d%.%-]", pos) then return number(s, pos) end
  local w = smatch(s, "^[%a_][%w_]*", pos)
  if w == "true" then return true, pos + 4 end
  if w == "false" then return false, pos + 5 end
  if w then fail(pos, "'%s' is not a value: expected %s (nothing is evaluated)", w, EXPECTED) end
  fail(pos, "expected %s, found %s", EXPECTED, shown(s, pos))
end

--- The value at init (after blanks) and the position after it and the blanks that follow.
local function read_at(s, init)
  local v, stop = value(s, skip(s, init), 1)
  return v, skip(s, stop)
end

--- The literal at text[init..] (init: default 1). --> value, the position after it and the blanks and comments
--- after it | nil, err, col
function M.prefix(text, init)
  init = init or 1
  if type(text) ~= "string" then return nil, "expected text, got " .. type(text), 1 end
  if #text > M.MAX_LENGTH then return nil, sformat("longer than %d bytes", M.MAX_LENGTH), M.MAX_LENGTH + 1 end
  local ok, v, stop = pcall(read_at, text, init)
  if ok then return v, stop end
  if type(v) == "table" then return nil, v.msg, v.pos end
  return nil, "cannot read the value: " .. tostring(v), init
end

--- The whole of text as one literal (blanks and `--` comments around it). --> value | nil, err, col
function M.read(text)
  local v, stop, col = M.prefix(text, 1)
  if v == nil then return nil, stop, col end
  if stop <= #text then return nil, sformat("unexpected %s after the value", shown(text, stop)), stop end
  return v
end

--- Whether `v`, a value built in Lua rather than read, is one the grammar above can write: a finite number, a
--- string, a boolean, or a table of them (keys: numbers, strings, booleans) at most MAX_DEPTH deep; never
--- raises. --> true | nil, reason
function M.check(v, depth)
  depth = depth or 0
  local t = type(v)
  if t == "number" then
    if v ~= v or v == math.huge or v == -math.huge then return nil, "a number must be finite, got " .. tostring(v) end
    return true
  end
  if t == "string" or t == "boolean" then return true end
  if t ~= "table" then return nil, "a value is a number, a string, a boolean or a table, not a " .. t end
  if depth >= M.MAX_DEPTH then return nil, sformat("tables nest at most %d deep", M.MAX_DEPTH) end
  for k, x in pairs(v) do
    local kt = type(k)
    if kt ~= "number" and kt ~= "string" and kt ~= "boolean" then return nil, "a table key must be a number, a string or a boolean" end
    local ok, why = M.check(k, depth + 1)
    if ok then ok, why = M.check(x, depth + 1) end
    if not ok then return nil, why end
  end
  return true
end

return M
