-- dca.literal: the literal-only reader of configuration values. Values read as Lua reads them; code (the
-- hostile values) is an error at its column and never runs; random and mutated inputs never raise,
-- hang or execute.
local T = require "dca.testing"
local literal = require "dca.literal"
local suite = T.suite("literal")

suite:case("numbers_strings_booleans_and_tables_read_as_lua_reads_them", function()
  local cases = {
    "0", "75", "-3", "- 3", "0.45", "-0.45", ".5", "3.", "1e3", "2E+10", "1e-3", "0xff", "0XA.8", "0x1p4", "-0x10",
    "9223372036854775807", "9223372036854775808", "0x7fffffffffffffff", "0x00000000000000000001", "1e308", "true", "false", '"right"', "'right'", '"a\\tb\\n\\"q\\"\\\\"',
    "'\\65\\066\\x43\\u{48}\\z   x'", '"a\\\nb"', "[[long]]", "[==[a]]b]==]", "{}", "{1, 2, 3}", "{1; 2;}",
    '{a = 1, ["b"] = 2, [3] = "c", [true] = false}', "{ {1, {2, {3}}}, x = { y = { z = -1.5 } } }",
    "{[1] = 'a', 'b'}", "  42  -- the answer", "{1, -- one\n 2}",
  }
  for _, text in ipairs(cases) do
    local want = load("return " .. text, "=want", "t", {})()  -- only the test compares with Lua itself
    local v, err, col = literal.read(text)
    T.eq(v, want, text .. " (" .. tostring(err) .. " at " .. tostring(col) .. ")")
    T.eq(math.type(v), math.type(want), text .. ": integer or float")
  end
end)

suite:case("code_and_non_literals_are_errors_at_the_offending_column", function()
  local cases = {
    { "(function() while true do end end)()", 1, "found '('" },
    { "os.exit(3)", 1, "'os' is not a value" },
    { "{1, os.exit(3)}", 5, "'os' is not a value" },
    { "{x = print}", 6, "'print' is not a value" },
    { "1 + 1", 3, "unexpected '+' after the value" },
    { '"a" .. "b"', 5, "unexpected '.' after the value" },
    { "{1, 2", 6, "found the end of the text" },
    { "{1,,2}", 4, "found ','" },
    { "{[{}] = 1}", 3, "a table key must be" },
    { "{true = 1}", 7, "expected ',' or '}'" },
    { "nil", 1, "'nil' is not a value" },
    { "", 1, "found the end of the text" },
    { "3x", 1, "malformed number near '3x'" },
    { "0x", 1, "malformed number" },
    { "1e", 1, "malformed number" },
    { "1..2", 1, "malformed number" },
    { "+1", 1, "found '+'" },
    { "inf", 1, "'inf' is not a value" },
    { '"open', 1, "unfinished string" },
    { '"line\nbreak"', 6, "a line break" },
    { '"\\q"', 2, "invalid escape sequence '\\q'" },
    { '"\\256"', 2, "decimal escape" },
    { '"\\xZZ"', 2, "hexadecimal digits" },
    { '"\\u{110000000}"', 2, "\\u{XXX}" },
    { "[[open", 1, "unfinished long string" },
    { "function() end", 1, "'function' is not a value" },
    { "{...}", 2, "malformed number near '...'" },
    { "\0", 1, "byte \\0" },
    -- numbers out of range: Lua would read inf, or wrap a hexadecimal integer around to -1
    { "1e999", 1, "number out of range: 1e999" },
    { "{t = -1e400}", 6, "number out of range: -1e400" },
    { "0x7fffffffffffffffff", 1, "integer out of range" },
    { "0xffffffffffffffff", 1, "integer out of range" },
  }
  for _, c in ipairs(cases) do
    local v, err, col = literal.read(c[1])
    T.eq(v, nil, c[1])
    T.contains(err, c[3], c[1])
    T.eq(col, c[2], "column of the error in " .. c[1] .. " (" .. err .. ")")
  end
end)

suite:case("depth_and_length_are_bounded", function()
  local deep = ("{"):rep(literal.MAX_DEPTH) .. ("}"):rep(literal.MAX_DEPTH)
  T.ok(type(literal.read(deep)) == "table", "MAX_DEPTH nested tables read")
  local v, err, col = literal.read(("{"):rep(100000))
  T.eq(v, nil)
  T.contains(err, "nested deeper than " .. literal.MAX_DEPTH)
  T.eq(col, literal.MAX_DEPTH + 1)
  v, err = literal.read(string.rep(" ", literal.MAX_LENGTH) .. "1")
  T.eq(v, nil)
  T.contains(err, "longer than")
  T.eq(literal.read(string.rep(" ", literal.MAX_LENGTH - 1) .. "1"), 1)
  T.eq(#literal.read('"' .. string.rep("x", 100000) .. '"'), 100000)
end)

suite:case("prefix_gives_the_position_after_the_value", function()
  local v, stop = literal.prefix("0.5   # seconds", 1)
  T.eq({ v, stop }, { 0.5, 7 })
  v, stop = literal.prefix("x = {1} -- one\n", 5)
  T.eq({ v, stop }, { { 1 }, 16 })
  T.eq({ literal.prefix(42) }, { nil, "expected text, got number", 1 })
end)

-- Runs fn with an instruction budget and no way to reach the outside: a hang or a raise fails the test.
local BUDGET = 20000000
local function bounded(input, fn)
  local co = coroutine.create(fn)
  debug.sethook(co, function() error("instruction budget exhausted (hang?)") end, "", BUDGET)
  local ok, a, b, c = coroutine.resume(co, input)
  if not ok then error(string.format("literal.read raised on %s:\n%s", T.show(input), tostring(a)), 0) end
  return a, b, c
end

local SEEDS = { "(function() while true do end end)()", "os.exit(3)", "{1, 2, a = 'x', [\"b\"] = {true, false}}",
  "-0x1p4", '"esc\\n\\t\\x41\\065\\u{48}\\z  "', "[==[long]==]", "{ {{{}}} }", "1e-3", "io.write('pwned')",
  "setmetatable({}, {__gc = os.exit})", "string.rep('x', 1e9)", "{[1]=2;[3]=4,}", "error('x')" }
local TOKENS = { "{", "}", "[", "]", "(", ")", "=", ",", ";", "'", '"', "\\", "--", "[[", "]]", "-", ".", "e",
  "0x", "true", "nil", "os.exit(1)", "\n", "\0", " ", "9", "function", "end", "..", "#", "\\u{", "\\x", "\\z" }

local function mutate(s, rnd)
  local i = rnd(#s + 1)
  local kind = rnd(5)
  if kind == 1 then return s:sub(1, i - 1) .. s:sub(i + rnd(8)) end
  if kind == 2 then return s:sub(1, i - 1) .. TOKENS[rnd(#TOKENS)] .. s:sub(i) end
  if kind == 3 then return s:sub(1, i - 1) .. string.char(rnd(256) - 1) .. s:sub(i + 1) end
  if kind == 4 then return s:sub(1, i) end
  return s:sub(1, i) .. s:sub(i, math.min(#s, i + rnd(10))) .. s:sub(i + 1)
end

suite:case("random_and_mutated_inputs_never_raise_hang_or_execute", function()
  math.randomseed(14)
  local rnd = math.random
  local executed = false
  local saved = { os.exit, io.write, error, print, string.rep, setmetatable }
  os.exit = function() executed = true end                      -- luacheck: ignore
  io.write = os.exit                                           -- luacheck: ignore
  print = os.exit                                              -- luacheck: ignore
  local runs, values = 0, 0
  local ok, err = pcall(function()
    for round = 1, 600 do
      local s = SEEDS[rnd(#SEEDS)]
      for _ = 1, rnd(6) do s = mutate(s, rnd) end
      if round % 5 == 0 then  -- a random token soup
        local parts = {}
        for i = 1, rnd(30) do parts[i] = TOKENS[rnd(#TOKENS)] end
        s = table.concat(parts)
      end
      local v, e, col = bounded(s, literal.read)
      runs = runs + 1
      if v == nil then
        T.ok(type(e) == "string" and math.type(col) == "integer" and col >= 1 and col <= #s + 1,
             "an error with its column for " .. T.show(s) .. ": " .. T.show({ e, col }))
      else
        values = values + 1
        T.ok(type(v) ~= "function" and type(v) ~= "userdata", "data only for " .. T.show(s))
      end
    end
  end)
  os.exit, io.write, error, print, string.rep, setmetatable = table.unpack(saved)  -- luacheck: ignore
  T.ok(ok, tostring(err))
  T.ok(not executed, "nothing executed")
  T.ok(runs == 600 and values > 5, "runs " .. runs .. ", values " .. values)
end)

return suite:run(...)
