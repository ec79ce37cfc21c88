-- dca.verify.props: properties in the system's own terms, written in a process's `verify { }` section and
-- checked by `dca check --verify` on that group's states. Each property ends with ';'. Names are the group's
-- instances (the group's own process name for `can end`):
--
--   closegrip never starts before hit is done;        every start of closegrip comes after a DONE of hit
--                                                      (since hit's last start)
--   presshandle always ends before dooropen starts;    when dooropen starts, presshandle has run and ended
--   motionctrl runs while any step runs;               motionctrl runs whenever another operand runs
--   motionctrl runs while approach runs;
--   main can end done;                                 some run ends DONE (also: aborted; or just `can end`)
--   main cannot end aborted;                           no run ends ABORTED (`cannot end`: none ends at all)
--   never (approach and presshandle running);          never both (or all the named) at once
--   exclusive motionctrl.In;                            one writer at a time on that input (dca.verify.writers)
--
--   local props = require "dca.verify.props"
--   local list, errors = props.parse(section, file_index_fn)
--   -- section: the AST's proc.verify { text, pos } ; errors: { { pos, msg } ... } (file positions)
local M = {}

local ipairs, pairs, pcall, error, type = ipairs, pairs, pcall, error, type
local sformat, sfind, ssub, concat = string.format, string.find, string.sub, table.concat

-- Tokens of the section's text: { kind = "name" | "(" | ")" | ";", text, pos (file offset) }.
local function tokens(text, base)
  local out, i, n = {}, 1, #text
  while i <= n do
    local s, e = sfind(text, "^[%s]+", i)
    if s then i = e + 1 end
    if i > n then break end
    local c = ssub(text, i, i)
    local ns, ne = sfind(text, "^[%a_][%w_]*", i)
    if ns then
      out[#out + 1] = { kind = "name", text = ssub(text, ns, ne), pos = base + ns - 1 }
      i = ne + 1
    elseif c == "(" or c == ")" or c == ";" or c == "." then
      out[#out + 1] = { kind = c, text = c, pos = base + i - 1 }
      i = i + 1
    else
      return nil, { pos = base + i - 1, msg = sformat("unexpected '%s' in a property", c) }
    end
  end
  return out
end

local PATTERNS = [[the properties are: A never starts before B is done; A always ends before B starts; ]] ..
  [[A runs while any step runs; A runs while B runs; G can end [done|aborted]; G cannot end [done|aborted]; ]] ..
  [[never (A and B running); exclusive A.PORT]]

-- A reader over one property's tokens with labelled failures.
local function reader(toks, first, last, fail_at)
  local r = { i = first }
  function r.peek(k) local t = toks[r.i + (k or 0)] return t and r.i + (k or 0) <= last and t or nil end
  function r.word(w)
    local t = r.peek()
    if t and t.kind == "name" and t.text == w then r.i = r.i + 1 return t end
    return nil
  end
  function r.expect_word(w, what)
    local t = r.word(w)
    if t then return t end
    local at = r.peek()
    fail_at(at and at.pos or toks[last].pos, sformat("expected '%s' %s, found %s", w, what,
      at and ("'" .. at.text .. "'") or "the end of the property"))
  end
  function r.name(what)
    local t = r.peek()
    if t and t.kind == "name" then r.i = r.i + 1 return t end
    fail_at(t and t.pos or toks[last].pos, sformat("expected %s, found %s", what,
      t and ("'" .. t.text .. "'") or "the end of the property"))
  end
  function r.done() return r.i > last end
  return r
end

-- never ( A and B ... running )
local function parse_never(r, fail_at, at)
  local open = r.peek()
  if not (open and open.kind == "(") then fail_at(open and open.pos or at, "expected '(' after 'never'") end
  r.i = r.i + 1
  local names = { r.name("an instance name after 'never ('") }
  while r.word("and") do names[#names + 1] = r.name("an instance name after 'and'") end
  r.expect_word("running", "after the names (write never (A and B running))")
  local close = r.peek()
  if not (close and close.kind == ")") then fail_at(close and close.pos or at, "expected ')' after 'running'") end
  r.i = r.i + 1
  if #names < 2 then fail_at(names[1].pos, "'never (...)' names at least two instances joined by 'and'") end
  return { kind = "exclusive", names = names }
end

-- A ... (the forms that start with a name)
local function parse_named(r, fail_at, a)
  local w = r.peek()
  if not w or w.kind ~= "name" then fail_at(w and w.pos or a.pos, "expected a property after '" .. a.text .. "' (" .. PATTERNS .. ")") end
  if r.word("never") then
    r.expect_word("starts", "after '" .. a.text .. " never'")
    r.expect_word("before", "after 'starts'")
    local b = r.name("an instance name after 'before'")
    r.expect_word("is", "after '" .. b.text .. "' (write: is done)")
    r.expect_word("done", "after 'is'")
    return { kind = "starts_after_done", a = a, b = b }
  elseif r.word("always") then
    r.expect_word("ends", "after '" .. a.text .. " always'")
    r.expect_word("before", "after 'ends'")
    local b = r.name("an instance name after 'before'")
    r.expect_word("starts", "after '" .. b.text .. "'")
    return { kind = "ends_before_start", a = a, b = b }
  elseif r.word("runs") then
    r.expect_word("while", "after 'runs'")
    if r.word("any") then
      r.expect_word("step", "after 'any'")
      r.expect_word("runs", "after 'any step'")
      return { kind = "runs_while", a = a, any = true }
    end
    local b = r.name("an instance name or 'any step' after 'while'")
    r.expect_word("runs", "after '" .. b.text .. "'")
    return { kind = "runs_while", a = a, b = b }
  end
  local cw = r.word("can") or r.word("cannot")
  if cw then
    r.expect_word("end", "after '" .. cw.text .. "'")
    local how = r.word("done") or r.word("aborted")
    return { kind = "can_end", a = a, how = how and how.text or nil, negated = cw.text == "cannot" }
  end
  fail_at(w.pos, sformat("unknown property '%s %s ...' (%s)", a.text, w.text, PATTERNS))
end

-- One property from tokens first..last (without its ';').
local function parse_one(toks, first, last, fail_at)
  local r = reader(toks, first, last, fail_at)
  local t = r.peek()
  local p
  if t.kind == "name" and t.text == "never" then
    r.i = r.i + 1
    p = parse_never(r, fail_at, t.pos)
  elseif t.kind == "name" and t.text == "exclusive" and r.peek(2) and r.peek(2).kind == "." then
    r.i = r.i + 1
    local a = r.name("an instance name after 'exclusive'")
    r.i = r.i + 1
    p = { kind = "one_writer", a = a, port = r.name("an input port after '" .. a.text .. ".'") }
  elseif t.kind == "name" then
    r.i = r.i + 1
    p = parse_named(r, fail_at, t)
  else
    fail_at(t.pos, "expected a property, found '" .. t.text .. "' (" .. PATTERNS .. ")")
  end
  if not r.done() then fail_at(r.peek().pos, "unexpected '" .. r.peek().text .. "' after the property (end it with ';')") end
  p.pos = t.pos
  local words = {}
  for k = first, last do words[#words + 1] = toks[k].text end
  p.text = (concat(words, " "):gsub("%( ", "("):gsub(" %)", ")"):gsub(" %. ", "."))
  return p
end

--- Parses the text of a verify section (file offset `base` of its first character; comments already blanked).
--- Returns the properties (each { kind, text, pos, ... }) and a list of errors { pos, msg } (file offsets).
function M.parse(text, base)
  local toks, terr = tokens(text, base)
  if not toks then return {}, { terr } end
  local list, errors = {}, {}
  local first = 1
  for k = 1, #toks + 1 do
    local t = toks[k]
    if not t or t.kind == ";" then
      if not t and first <= #toks then
        errors[#errors + 1] = { pos = toks[#toks].pos + #toks[#toks].text, msg = "expected ';' at the end of the property" }
      elseif t and k == first then
        errors[#errors + 1] = { pos = t.pos, msg = "empty property before ';'" }
      elseif t then
        local ok, p = pcall(parse_one, toks, first, k - 1, function(pos, msg) error({ pos = pos, msg = msg }, 0) end)
        if ok then list[#list + 1] = p
        elseif type(p) == "table" then errors[#errors + 1] = p
        else error(p, 0) end
      end
      first = k + 1
    end
  end
  return list, errors
end

--- The names a property refers to (tokens with text and pos).
function M.names(p)
  if p.kind == "exclusive" then return p.names end
  local out = { p.a }
  if p.b then out[2] = p.b end
  return out
end

--- The properties of process definition `proc`'s verify section (nil: none), each name checked against its
--- instances (`can end` also takes the process's own name and the names in `own`, a set: the instances of it).
--- Returns the list and the errors { pos, msg } (file offsets). `dca check` reports these errors with the
--- file's other ones (dca.lang.check); `--verify` checks the properties.
function M.of_process(proc, own)
  local v = proc.verify
  if not v then return {}, {} end
  local list, errors = M.parse(v.text, v.pos)
  local inst = {}
  for _, i in ipairs(proc.instances) do inst[i.name] = true end
  for _, p in ipairs(list) do
    for _, n in ipairs(M.names(p)) do
      local self = p.kind == "can_end" and (n.text == proc.name or (own and own[n.text]))
      if not self and not inst[n.text] then
        errors[#errors + 1] = { pos = n.pos, msg = sformat("no instance '%s' in process '%s'", n.text, proc.name) }
      end
    end
  end
  return list, errors
end

------------------------------------------------------------------------------------------- monitors

-- A monitor sees each step of the exploration (dca.verify.explore): step(ch, step, rec, running) -> next ch,
-- violated; or each state: state(running) -> violated. ch is its one-character state.

local function starts_after_done(p)
  local a, b = p.a.text, p.b.text
  return { initial = "0", step = function(ch, step, rec)
    if step.name == b and step.ev.kind == "done" then ch = "1" end
    for _, cmd in ipairs(rec.cmds) do
      if cmd[1] == "start" and cmd[2] == a and ch == "0" then return ch, true end
      if cmd[1] == "start" and cmd[2] == b then ch = "0" end
    end
    return ch, false
  end }
end

local function ends_before_start(p)
  local a, b = p.a.text, p.b.text
  return { initial = "0", step = function(ch, step, rec)
    if step.name == a then ch = "1" end
    for _, cmd in ipairs(rec.cmds) do
      if cmd[2] == a then ch = cmd[1] == "abort" and "1" or "0" end
      if cmd[1] == "start" and cmd[2] == b and ch == "0" then return ch, true end
    end
    return ch, false
  end }
end

local function runs_while(p, operands)
  local a = p.a.text
  local others = {}
  if p.any then
    for name in pairs(operands) do if name ~= a then others[#others + 1] = name end end
  else
    others[1] = p.b.text
  end
  return { state = function(running)
    if running[a] then return false end
    for _, o in ipairs(others) do if running[o] then return true end end
    return false
  end }
end

local function exclusive(p)
  return { state = function(running)
    for _, n in ipairs(p.names) do if not running[n.text] then return false end end
    return true
  end }
end

--- The monitor of a property over a group whose operands are `operands` (name -> behaviour), or nil for the
--- properties decided on the outcomes (can_end). m.names: the names it watches (m.all: every operand's), which
--- the explorer's reduction leaves alone.
function M.monitor(p, operands)
  local m
  if p.kind == "starts_after_done" then m = starts_after_done(p)
  elseif p.kind == "ends_before_start" then m = ends_before_start(p)
  elseif p.kind == "runs_while" then m = runs_while(p, operands)
  elseif p.kind == "exclusive" then m = exclusive(p)
  else return nil end
  m.names, m.all = {}, p.any or nil
  for i, n in ipairs(M.names(p)) do m.names[i] = n.text end
  return m
end

return M
