-- Seeded fuzzing of the language tools: random and mutated inputs (from scripts/systems/*.dca, the golden
-- files and generated expressions) never raise a Lua error and never hang (an instruction budget per input),
-- and generated expressions keep the interpreter's invariants under random event sequences.
local T = require "dca.testing"
local parser = require "dca.lang.parser"
local check = require "dca.lang.check"
local model = require "dca.lang.model"
local algebra = require "dca.algebra"
local suite = T.suite("fuzz")

local src, read = T.src, T.read
local here = T.here()

local function corpus()
  local files = {}
  for _, dir in ipairs({ src .. "/scripts/systems", here .. "/golden" }) do
    for _, name in ipairs(T.list(dir, "%.dca$")) do files[#files + 1] = read(dir .. "/" .. name) end
  end
  assert(#files >= 3, "fuzz corpus not found under " .. src)
  return files
end

-- Runs fn(...) with an instruction budget: a runaway loop fails the test instead of hanging it.
local BUDGET = 50000000
local function bounded(what, input, fn, ...)
  local args = table.pack(...)
  local co = coroutine.create(function() return fn(table.unpack(args, 1, args.n)) end)
  debug.sethook(co, function() error("instruction budget exhausted (hang?)") end, "", BUDGET)
  local res = table.pack(coroutine.resume(co))
  if not res[1] then
    error(string.format("%s raised on input %s:\n%s", what, T.show(input), tostring(res[2])), 0)
  end
  return table.unpack(res, 2, res.n)
end

local TOKENS = { "process", "host", "instantiated_processes", "external_io", "internal_connections",
                 "internal_event_actions", "instof", "{", "}", "(", ")", ";", ",", ":", ":;", "#", "->", "=", "[",
                 "]", "\"", "//", "/*", "*/", "\n", " ", "a", "B1", "_x", "42", "-3.5", "\"str\"", ".", "\t",
                 "external iof", "internal connections", "main", "Timer" }

local function mutate(s, rnd)
  local n = #s
  local kind = rnd(7)
  local i = rnd(n + 1)
  if kind == 1 then                       -- delete a range
    local j = math.min(n, i + rnd(20))
    return s:sub(1, i - 1) .. s:sub(j + 1)
  elseif kind == 2 then                   -- insert a token
    return s:sub(1, i - 1) .. TOKENS[rnd(#TOKENS)] .. s:sub(i)
  elseif kind == 3 then                   -- replace a byte by a random byte
    return s:sub(1, i - 1) .. string.char(rnd(256) - 1) .. s:sub(i + 1)
  elseif kind == 4 then                   -- duplicate a range
    local j = math.min(n, i + rnd(40))
    return s:sub(1, j) .. s:sub(i, j) .. s:sub(j + 1)
  elseif kind == 5 then                   -- truncate
    return s:sub(1, i)
  elseif kind == 6 then                   -- swap two bytes
    local j = rnd(n + 1)
    if i > n or j > n then return s end
    local a, b = math.min(i, j), math.max(i, j)
    if a == b then return s end
    return s:sub(1, a - 1) .. s:sub(b, b) .. s:sub(a + 1, b - 1) .. s:sub(a, a) .. s:sub(b + 1)
  end
  return s:upper()
end

local function check_result(input, ast, err)
  if ast then
    T.ok(type(ast) == "table" and type(ast.processes) == "table", "an AST")
    local errors = bounded("check.check", input, check.check, ast, { types = {} })
    T.ok(type(errors) == "table", "a list of errors")
    for _, e in ipairs(errors) do
      T.ok(type(e.line) == "number" and type(e.col) == "number" and type(e.msg) == "string", "error fields")
      bounded("check.format", input, check.format, ast, e)
    end
    bounded("model.build", input, model.build, ast)
  else
    T.ok(type(err) == "string", "a message")
    T.ok(err:match("^f%.dca:%d+:%d+: [^\n]+\n[^\n]*\n *\t* *%^$") or err:match("^f%.dca:%d+:%d+: "),
         "file:line:col format: " .. T.show(err))
  end
end

suite:case("parser_mutated_system_files", function()
  math.randomseed(20011029)
  local rnd = math.random
  local files = corpus()
  for _ = 1, 2500 do
    local s = files[rnd(#files)]
    for _ = 1, rnd(4) do s = mutate(s, rnd) end
    local ast, err = bounded("parser.parse", s, parser.parse, s, "f.dca")
    check_result(s, ast, err)
  end
end)

suite:case("parser_random_token_soup", function()
  math.randomseed(4711)
  local rnd = math.random
  for _ = 1, 3000 do
    local parts = {}
    for k = 1, rnd(60) do
      parts[k] = rnd(5) == 1 and string.char(rnd(256) - 1) or TOKENS[rnd(#TOKENS)]
    end
    local s = table.concat(parts, rnd(2) == 1 and " " or "")
    local ast, err = bounded("parser.parse", s, parser.parse, s, "f.dca")
    check_result(s, ast, err)
  end
end)

-- A random expression over the names N1..Nk (possibly repeated, labelled, parenthesised).
local OPS = { ",", ";", "#", ":", ":;" }
local function gen_expr(rnd, depth, names)
  if depth <= 0 or rnd(3) == 1 then
    local n = names[rnd(#names)]
    if rnd(4) == 1 then n = n .. "[l" .. rnd(2) .. "]" end
    return n
  end
  local op = OPS[rnd(#OPS)]
  local k = (op == ":" or op == ":;") and 2 or (1 + rnd(3))
  local parts = {}
  for i = 1, k do parts[i] = gen_expr(rnd, depth - 1, names) end
  local s = table.concat(parts, " " .. op .. " ")
  if rnd(2) == 1 then s = "(" .. s .. ")" end
  return s
end

suite:case("algebra_parse_random_and_mutated_text", function()
  math.randomseed(99)
  local rnd = math.random
  local names = { "A", "B", "C", "D", "E", "F" }
  local accepted = 0
  for _ = 1, 4000 do
    local s = gen_expr(rnd, 4, names)
    if rnd(2) == 1 then s = mutate(s, rnd) end
    local e, err, info = bounded("algebra.parse", s, algebra.parse, s)
    if e then
      accepted = accepted + 1
      -- the canonical text parses to the same canonical text
      local text = algebra.tostring(e)
      local e2 = assert(algebra.parse(text), text)
      T.eq(algebra.tostring(e2), text, "round trip of " .. s)
    else
      T.ok(type(err) == "string" and err:match("column %d+: "), "message with column: " .. T.show(err))
      T.ok(type(info.pos) == "number" and info.pos >= 1 and info.pos <= #s + 1, "position in range")
    end
  end
  T.ok(accepted > 500, "enough valid expressions: " .. accepted)
end)

-- Drives a run with random events and checks SEMANTICS.md's invariants after every step.
local function drive(rnd, e, text)
  local running, active = {}, {}
  local run
  local function fail(msg) error(msg .. " in " .. text, 0) end
  run = assert(algebra.new(e, {
    start = function(n)
      if running[n] then fail("started " .. n .. " while it runs") end
      running[n] = true
    end,
    abort = function(n)
      if not running[n] then fail("aborted " .. n .. " which does not run") end
      running[n] = nil
    end,
    activate = function(n, l)
      if running[n] then fail("activate " .. n .. " while it runs") end
      active[n] = l
    end,
    deactivate = function(n, l)
      if active[n] ~= l then fail("deactivate " .. n .. "[" .. l .. "] not active") end
      if running[n] then fail("deactivate " .. n .. " while it runs") end
      active[n] = nil
    end,
  }))
  run:start(rnd(2) == 1 and "init" or nil)
  for _ = 1, 60 do
    local st = run:status()
    if st ~= "running" then break end
    local r = rnd(20)
    if r == 1 then
      run:abort()
    else
      local n = e.names[rnd(#e.names)]
      local kinds = { "done", "done", "done", "aborted", "error" }
      local kind = kinds[rnd(#kinds)]
      local was = running[n]
      running[n] = nil   -- the event ends that run (the interpreter may start n again while handling it)
      local taken = run:event(n, kind, rnd(100))
      if taken ~= (was == true) then fail("event " .. n .. " taken=" .. tostring(taken)) end
    end
    -- the run's view equals ours
    local mine = {}
    for n in pairs(running) do mine[#mine + 1] = n end
    table.sort(mine)
    local theirs = {}
    for _, s in ipairs(run:running()) do theirs[#theirs + 1] = (s:gsub("%[.*$", "")) end
    table.sort(theirs)
    T.eq(theirs, mine, "running set of " .. text)
  end
  local st = run:status()
  if st ~= "running" then
    T.ok(next(running) == nil, "nothing runs after the end: " .. text)
    T.ok(next(active) == nil, "no label active after the end: " .. text)
  end
end

suite:case("algebra_runs_keep_invariants", function()
  math.randomseed(1989)
  local rnd = math.random
  local names = { "A", "B", "C", "D", "E", "F", "G", "H" }
  local ran = 0
  for _ = 1, 3000 do
    local s = gen_expr(rnd, 5, names)
    local e = algebra.parse(s)
    if e then
      ran = ran + 1
      bounded("algebra run", s, drive, rnd, e, s)
    end
  end
  T.ok(ran > 300, "enough runs: " .. ran)
end)

return suite:run(...)
