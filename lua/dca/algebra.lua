-- dca.algebra: the DCA process-algebra interpreter (specification: shared/SEMANTICS.md).
--
-- Pure Lua: no I/O, no clock. The supervisor feeds events in, the interpreter answers with commands.
--
--   local algebra = require "dca.algebra"
--   local expr, err, info = algebra.parse("hit # (forcedata[lbl1], compliant[lbl1], puma)")
--   -- err: "column 5: ..." (or "line 2, column 5: ..." for multi-line text);
--   -- info: { msg = <message without position>, pos = <byte offset>, line = , col = }
--   local run = algebra.new(expr, {                  -- commands to the outside world (all optional)
--     start = function(name, init) end, abort = function(name) end,
--     activate = function(name, label) end,          -- just before start(name) of a labelled leaf
--     deactivate = function(name, label) end,        -- just after the run of a labelled leaf ended
--     is_running = function(name) return false end,  -- started by someone else? (SEMANTICS.md §4 item 1)
--     log = function(line) end,                      -- errors worth a log line ("process X already running")
--   })
--   run:start(init)                     -- init optional; true if the expression is running afterwards
--   run:event(name, "done", value)      --> true if taken, false if stale and ignored (SEMANTICS.md §3)
--   run:event(name, "aborted", reason) ; run:event(name, "error", reason)
--   run:abort()                         -- abort from outside (one LIFO abort operation on the root)
--   run:status()                        --> "idle" | "running" | "done" | "aborted", value
--   run:running()                       --> leaves running now, in start order: { "A", "B[l1]" }
--   run:is_running(name)                --> true if this expression runs the leaf `name` now
--   run:render(mark)                    --> the expression's text with running leaves marked (default *A*)
--   run:log()                           --> the latest commands and events, oldest first (strings)
--   run:snapshot() / run:restore(s)     --> a copy of the run's state, and back (dca.verify explores with it)
--
-- Expression objects (from parse) are immutable and may be shared by many runs:
--   expr.text     the source text
--   expr.root     the tree: { op = "leaf", name =, label =, pos =, stop =, line =, col = } or
--                 { op = "," | ";" | "#" | ":" | ":;", kids = { node, ... }, pos =, line =, col = }
--   expr.leaves   every leaf node in text order
--   expr.names    the distinct process names in order of first occurrence
--   algebra.tostring(expr) gives a canonical text that parses to the same tree.
--
-- Commands issued from inside a command callback must not call back into the run synchronously; if an
-- event arrives while the run is busy it is queued, processed after the current one (run to completion),
-- and event() returns nil for it.
local M = {}

local type, setmetatable, getmetatable, tostring, error, pcall, ipairs, pairs =
  type, setmetatable, getmetatable, tostring, error, pcall, ipairs, pairs
local sbyte, ssub, sfind, sformat = string.byte, string.sub, string.find, string.format
local concat = table.concat

-- Operator codes of the compiled form.
-- (<const>, one a line: compiled into the instructions that use them, no upvalue read; Lua folds only the
-- last name of a multiple declaration.)
local LEAF <const> = 0
local PAR <const> = 1
local SEQ <const> = 2
local DIS <const> = 3
local COND <const> = 4
local REC <const> = 5
local OPCODE = { leaf = LEAF, [","] = PAR, [";"] = SEQ, ["#"] = DIS, [":"] = COND, [":;"] = REC }
-- Binding strength for printing: smaller binds tighter.
local LEVEL = { leaf = 0, [":"] = 1, [":;"] = 1, ["#"] = 2, [";"] = 3, [","] = 4 }

--- Parentheses nested deeper than this are rejected (keeps every walk's recursion bounded).
M.max_depth = 1000

---------------------------------------------------------------------------------------------- parsing

local function line_col(text, pos)
  local line, last = 1, 0
  local i = sfind(text, "\n", 1, true)
  while i and i < pos do
    line, last = line + 1, i
    i = sfind(text, "\n", i + 1, true)
  end
  return line, pos - last
end

local function printable(run)
  return (run:gsub("[%c\128-\255]", function(c) return sformat("\\%d", sbyte(c)) end))
end

-- A parse error: raised inside the parser as a table, turned into nil, err, info by M.parse.
local Err = {}
local function fail(pos, msg) error(setmetatable({ pos = pos, msg = msg }, Err), 0) end

-- Character classes (byte values).
local B_LPAR, B_RPAR, B_LBR, B_RBR = sbyte("("), sbyte(")"), sbyte("["), sbyte("]")
local B_COMMA, B_SEMI, B_COLON, B_HASH = sbyte(","), sbyte(";"), sbyte(":"), sbyte("#")

local function is_name_start(b) return b and ((b >= 65 and b <= 90) or (b >= 97 and b <= 122) or b == 95) end
local function is_digit(b) return b and b >= 48 and b <= 57 end

-- Token kinds
local T_NAME, T_OP, T_LPAR, T_RPAR = 1, 2, 3, 4

-- Scans the label `[name]` whose '[' is at `j`, after the process name `name`; returns the label and the
-- position after its ']'.
local function scan_label(text, name, j)
  local len = #text
  local k = sfind(text, "[^ \t\r\n\f\v]", j + 1)
  local c = k and sbyte(text, k)
  if c == B_RBR then fail(j, "empty label in '" .. name .. "[]'") end
  if not c then fail(j, "unterminated label after '" .. name .. "' (no ']')") end
  if not is_name_start(c) then
    if is_digit(c) or c == 95 then
      local e = sfind(text, "[^A-Za-z0-9_]", k) or len + 1
      fail(k, "invalid label name '" .. ssub(text, k, e - 1) .. "'")
    end
    fail(k, "unterminated label after '" .. name .. "' (expected a label name and ']')")
  end
  local e = sfind(text, "[^A-Za-z0-9_]", k) or len + 1
  local label = ssub(text, k, e - 1)
  local r = sfind(text, "[^ \t\r\n\f\v]", e)
  if not r or sbyte(text, r) ~= B_RBR then
    fail(j, "unterminated label '" .. name .. "[" .. label .. "' (no ']')")
  end
  return label, r + 1
end

-- Scans `text` into token arrays while checking the grammar with a two-state machine (expecting an
-- operand / expecting an operator), so that every error of SEMANTICS.md §2.3 gets its own message at the
-- right column. Returns kinds, values, labels, positions, count.
local function scan(text)
  local kinds, vals, labels, poss, ends, n = {}, {}, {}, {}, {}, 0
  local len = #text
  local i = 1
  local want_operand = true
  local prev = nil      -- kind of the previous token (nil at the start)
  local depth = 0
  local opens = {}      -- positions of unclosed '('
  local last_op_pos
  while true do
    i = sfind(text, "[^ \t\r\n\f\v]", i)
    if not i then break end
    local b = sbyte(text, i)
    if is_name_start(b) then
      local j = sfind(text, "[^A-Za-z0-9_]", i) or len + 1
      local name = ssub(text, i, j - 1)
      if not want_operand then fail(i, "missing operator before '" .. name .. "'") end
      local label
      if sbyte(text, j) == B_LBR then label, j = scan_label(text, name, j) end
      n = n + 1
      kinds[n], vals[n], labels[n], poss[n], ends[n] = T_NAME, name, label, i, j - 1
      want_operand, prev, i = false, T_NAME, j
    elseif is_digit(b) then
      local j = sfind(text, "[^A-Za-z0-9_]", i) or len + 1
      fail(i, "invalid process name '" .. ssub(text, i, j - 1) .. "' (a name starts with a letter or '_')")
    elseif b == B_COMMA or b == B_SEMI or b == B_HASH or b == B_COLON then
      local op, j = ssub(text, i, i), i + 1
      if b == B_COLON and sbyte(text, i + 1) == B_SEMI then op, j = ":;", i + 2 end
      if want_operand then
        if prev == T_OP then fail(i, "missing operand between '" .. vals[n] .. "' and '" .. op .. "'") end
        if prev == T_LPAR then fail(i, "missing operand after '(' before '" .. op .. "'") end
        fail(i, "missing operand before '" .. op .. "'")
      end
      n = n + 1
      kinds[n], vals[n], poss[n] = T_OP, op, i
      want_operand, prev, i, last_op_pos = true, T_OP, j, i
    elseif b == B_LPAR then
      if not want_operand then fail(i, "missing operator before '('") end
      depth = depth + 1
      if depth > M.max_depth then fail(i, "expression nested too deeply (more than " .. M.max_depth .. " levels)") end
      opens[depth] = i
      n = n + 1
      kinds[n], vals[n], poss[n] = T_LPAR, "(", i
      prev, i = T_LPAR, i + 1
    elseif b == B_RPAR then
      if depth == 0 then fail(i, "unbalanced parentheses: ')' without '('") end
      if prev == T_LPAR then fail(poss[n], "empty parentheses '()'") end
      if want_operand then fail(i, "missing operand between '" .. vals[n] .. "' and ')'") end
      opens[depth] = nil
      depth = depth - 1
      n = n + 1
      kinds[n], vals[n], poss[n] = T_RPAR, ")", i
      prev, i = T_RPAR, i + 1
    elseif b == B_LBR then
      if prev == T_RPAR then fail(i, "label must follow a process name, not ')'") end
      if prev == T_NAME then fail(i, "label must follow a process name directly (no space before '[')") end
      fail(i, "label must follow a process name")
    elseif b == B_RBR then
      fail(i, "unexpected ']' (no label is open)")
    else
      local j = sfind(text, "[A-Za-z0-9_ \t\r\n\f\v,;:#()%[%]]", i) or len + 1
      fail(i, "unknown operator '" .. printable(ssub(text, i, j - 1)) .. "'")
    end
  end
  if n == 0 then fail(1, "empty expression") end
  if prev == T_OP then fail(last_op_pos, "trailing operator '" .. vals[n] .. "' (missing operand at the end)") end
  if depth > 0 then fail(opens[depth], "unbalanced parentheses: '(' never closed") end
  return kinds, vals, labels, poss, ends
end

-- Recursive descent over a token list already known to be well formed.
local function build(kinds, vals, labels, poss, ends)
  local t = 1
  local parse_expr
  local function node(op, kids)
    return { op = op, kids = kids, pos = kids[1].pos }
  end
  local function atom()
    if kinds[t] == T_NAME then
      local leaf = { op = "leaf", name = vals[t], label = labels[t], pos = poss[t], stop = ends[t] }
      t = t + 1
      return leaf
    end
    -- '(' expr ')'
    t = t + 1
    local e = parse_expr()
    t = t + 1
    return e
  end
  local function cond()
    local left = atom()
    while kinds[t] == T_OP and (vals[t] == ":" or vals[t] == ":;") do
      local op = vals[t]
      t = t + 1
      left = node(op, { left, atom() })
    end
    return left
  end
  local function chain(op, sub)
    return function()
      local first = sub()
      if not (kinds[t] == T_OP and vals[t] == op) then return first end
      local kids = { first }
      while kinds[t] == T_OP and vals[t] == op do
        t = t + 1
        kids[#kids + 1] = sub()
      end
      return node(op, kids)
    end
  end
  parse_expr = chain(",", chain(";", chain("#", cond)))
  return parse_expr()
end

-- Assigns preorder ids and fills the compiled arrays.
local function compile(root)
  local c = { op = {}, parent = {}, cidx = {}, nk = {}, kids = {}, last = {}, name = {}, label = {},
              node = {} }
  local op, parent, cidx, nk, kids, last, name, label, nodes =
    c.op, c.parent, c.cidx, c.nk, c.kids, c.last, c.name, c.label, c.node
  local n = 0
  local function walk(nd, p, i)
    n = n + 1
    local id = n
    op[id], parent[id], cidx[id], nodes[id] = OPCODE[nd.op], p, i, nd
    nd.id = id
    if nd.op == "leaf" then
      name[id], label[id], nk[id] = nd.name, nd.label or false, 0
    else
      name[id], label[id] = false, false
      local ks = {}
      for j, k in ipairs(nd.kids) do ks[j] = walk(k, id, j) end
      kids[id], nk[id] = ks, #ks
    end
    last[id] = n
    return id
  end
  walk(root, 0, 0)
  c.n = n
  return c
end

-- SEMANTICS.md §10: a name may not appear in two operands of one ',' or '#'. Returns the offending
-- leaf (the earliest in the text) and the operator, or nil.
local function concurrency_violation(c)
  local best, best_op
  for id = 1, c.n do
    local o = c.op[id]
    if o == PAR or o == DIS then
      local owner = {}
      for _, k in ipairs(c.kids[id]) do
        for l = k, c.last[k] do
          if c.op[l] == LEAF then
            local nm = c.name[l]
            local ow = owner[nm]
            if ow and ow ~= k then
              if not best or c.node[l].pos < best.pos then best, best_op = c.node[l], (o == PAR and "," or "#") end
            elseif not ow then
              owner[nm] = k
            end
          end
        end
      end
    end
  end
  return best, best_op
end

local function where(text, pos)
  local line, col = line_col(text, pos)
  if sfind(text, "\n", 1, true) then return sformat("line %d, column %d", line, col), line, col end
  return sformat("column %d", col), line, col
end

--- Parses an expression. Returns the expression object, or nil, "column N: message", info
--- (info = { msg, pos, line, col }). Never raises, whatever the input.
function M.parse(text)
  if type(text) ~= "string" then
    return nil, "column 1: expression must be a string, got " .. type(text), { msg = "expression must be a string",
      pos = 1, line = 1, col = 1 }
  end
  local ok, a, b, c2, d, e = pcall(scan, text)
  local function err(pos, msg)
    local w, line, col = where(text, pos)
    return nil, w .. ": " .. msg, { msg = msg, pos = pos, line = line, col = col }
  end
  if not ok then
    if getmetatable(a) == Err then return err(a.pos, a.msg) end
    return err(1, "internal error: " .. tostring(a))
  end
  local ok2, root = pcall(build, a, b, c2, d, e)
  if not ok2 then return err(1, "internal error: " .. tostring(root)) end
  local compiled = compile(root)
  local bad, bad_op = concurrency_violation(compiled)
  if bad then
    return err(bad.pos, sformat("process '%s' may run concurrently with itself (it appears in two operands of one '%s')",
      bad.name, bad_op))
  end
  local leaves, names, seen = {}, {}, {}
  -- line and column of every node, in one forward pass (node positions never decrease in preorder)
  local line, line_start, nl = 1, 1, sfind(text, "\n", 1, true)
  for id = 1, compiled.n do
    local nd = compiled.node[id]
    while nl and nl < nd.pos do
      line, line_start = line + 1, nl + 1
      nl = sfind(text, "\n", nl + 1, true)
    end
    nd.line, nd.col = line, nd.pos - line_start + 1
    if nd.op == "leaf" then
      leaves[#leaves + 1] = nd
      if not seen[nd.name] then seen[nd.name] = true; names[#names + 1] = nd.name end
    end
  end
  return { text = text, root = root, leaves = leaves, names = names, c = compiled }
end

local function render(nd, mark)
  if nd.op == "leaf" then
    local s = nd.label and (nd.name .. "[" .. nd.label .. "]") or nd.name
    if mark then s = mark(nd, s) end
    return s
  end
  local lv = LEVEL[nd.op]
  local parts = {}
  for i, k in ipairs(nd.kids) do
    local s = render(k, mark)
    local kl = LEVEL[k.op]
    -- same-level n-ary children keep their parentheses (they are separate nodes); ':' is left-assoc
    local need = kl > lv or (kl == lv and k.op ~= "leaf" and not (lv == 1 and i == 1))
    parts[i] = need and ("(" .. s .. ")") or s
  end
  local sep = (nd.op == ":" or nd.op == ":;") and (" " .. nd.op .. " ") or
              (nd.op == "," and ", " or (" " .. nd.op .. " "))
  return concat(parts, sep)
end

--- The canonical text of an expression (or of a tree node): parses back to the same tree.
function M.tostring(expr)
  return render(expr.root or expr)
end

---------------------------------------------------------------------------------------------- running

local Run = {}
Run.__index = Run

local function noop() end

-- The log: a ring of the latest LOG_SIZE commands and events (Run:log() renders them). Entry i sits at slot
-- i & LOG_MASK of logc, as one integer: id * 16 + one of the codes below (id: the leaf's node id); logv holds
-- the entry's value for the codes that have one (a start's binding, an ignored event's name).
-- self.logi is the count of entries written, and says whether the run is busy (processing an event, a start or
-- an abort): then it is -1 - the count at the beginning, and the walk carries the count (`at`: start_node and
-- abort_range take it and give it back) until it is written back at the end. One field read and two writes
-- an event for both.
local LOG_SIZE <const> = 256
local LOG_MASK <const> = LOG_SIZE - 1
local L_START <const> = 1
local L_ABORT <const> = 3
local L_CONFLICT <const> = 4
local L_ABORT_ALL <const> = 5
local L_EVENT = { done = 8, aborted = 9, error = 10 }       -- "event A done"
local L_IGNORED = { done = 11, aborted = 12, error = 13 }   -- "ignored A done" (logv: the name)
local function log(self, code, v)
  local i = self.logi + 1
  self.logi = i
  i = i & LOG_MASK
  self.logc[i], self.logv[i] = code, v
end

-- A run's engine is a set of closures made once per run (M.new): the compiled arrays of its expression and
-- the run's state tables are their upvalues, so that an event costs no table lookup to reach them. The state
-- tables live as long as the run (Run:restore fills them in place):
--   rprev, rnext   the running leaves in start order: a circular doubly linked list through sentinel 0
--                  (rnext[0] the first started, rprev[0] the last)
--   byname         process name -> the running leaf's id
--   bind           SEQ, COND, REC node -> the binding it started with
--   cnt, vals      PAR node -> operands still running, values so far { n = operands }

-- abort_range(id, at) aborts every running leaf in the subtree of node `id`, most recently started first
-- (SEMANTICS.md §6), and gives back the log's count `at`.
local function make_abort(self, c, rprev, rnext, byname, cmd)
  local last, names, labels, logc = c.last, c.name, c.label, self.logc
  local cmd_abort, cmd_deactivate = cmd.abort or noop, cmd.deactivate or noop
  return function(id, at)
    local hi = last[id]
    local l = rprev[0]
    while l ~= 0 do
      local before = rprev[l]
      if l >= id and l <= hi then
        local nx = rnext[l]
        rnext[before], rprev[nx] = nx, before
        local nm = names[l]
        byname[nm] = nil
        cmd_abort(nm)
        at = at + 1  -- log: "abort A", and "-A[l]" for a labelled leaf (rendered by Run:log)
        logc[at & LOG_MASK] = l * 16 + L_ABORT
        local lb = labels[l]
        if lb then cmd_deactivate(nm, lb) end
      end
      l = before
    end
    return at
  end
end

-- start_node(root, b, at) starts node `root` with binding `b` (SEMANTICS.md §3 start order), its whole subtree
-- in one call (`at`: the log's count, given back second). Returns true when the node is running afterwards,
-- false when it ended ABORTED at once (a leaf whose process was already running); in that case nothing of the
-- subtree is left running.
local function make_start(self, c, st, cmd, abort_range)
  local op, parent, names, labels, kids, nk = c.op, c.parent, c.name, c.label, c.kids, c.nk
  local rprev, rnext, byname, bind, cnt, vals = st.rprev, st.rnext, st.byname, st.bind, st.cnt, st.vals
  local cmd_start, cmd_activate, cmd_log = cmd.start or noop, cmd.activate or noop, cmd.log or noop
  local is_running, logc, logv = cmd.is_running, self.logc, self.logv
  local pending = {}  -- the operands of ',' and '#' still to start, the next on top (no command re-enters)
  return function(root, b, at)
    local id, sp = root, 0
    local op, names, labels, rprev, rnext, byname, logc, logv = op, names, labels, rprev, rnext, byname, logc, logv  -- registers, not upvalues
    while true do
      local o = op[id]
      if o == LEAF then
        local nm = names[id]
        if byname[nm] or (is_running and is_running(nm)) then
          at = at + 1
          logc[at & LOG_MASK], logv[at & LOG_MASK] = id * 16 + L_CONFLICT, nil
          cmd_log("process " .. nm .. " already running: occurrence aborted")
          while id ~= root do  -- each ',' and '#' on the way up aborts what it started, innermost first
            id = parent[id]
            o = op[id]
            if o == PAR or o == DIS then at = abort_range(id, at) vals[id] = nil end
          end
          return false, at
        end
        local lb = labels[id]
        if lb then cmd_activate(nm, lb) end  -- logged as "+A[l]" with the start
        local t = rprev[0]  -- appended to the running leaves (start order)
        rprev[id] = t
        rnext[id] = 0
        rnext[t] = id
        rprev[0] = id
        byname[nm] = id
        cmd_start(nm, b)
        at = at + 1  -- log: "start A" (or "start A init=b"), after "+A[l]" for a labelled leaf
        local k = at & LOG_MASK
        logc[k] = id * 16 + L_START
        logv[k] = b
        if sp == 0 then return true, at end
        id, sp = pending[sp], sp - 1
      elseif o == PAR or o == DIS then  -- every operand, left to right
        local ks = kids[id]
        if o == PAR then  -- its values so far: a new list, or its own again if it never handed it up
          local n, t = nk[id], vals[id]
          cnt[id] = n
          if t then for k = 1, n do t[k] = nil end else vals[id] = { n = n } end
        end
        for k = #ks, 2, -1 do
          sp = sp + 1
          pending[sp] = ks[k]
        end
        id = ks[1]
      else  -- SEQ, COND, REC start their first operand only
        bind[id] = b
        id = kids[id][1]
      end
    end
  end
end

-- Run:event, made once per run: an event of the leaf process `name`; taken (true) when that leaf runs, else
-- ignored (false) as stale, or queued (nil) while the run is busy. A taken event ends the leaf with outcome
-- ok/v; then its ancestors react, upward, until one keeps running or the root ends (iterative: recurrence
-- never grows the stack).
local function make_event(self, c, st, cmd, start_node, abort_range)
  local parent, op, cidx, kids, nk, labels = c.parent, c.op, c.cidx, c.kids, c.nk, c.label
  local rprev, rnext, byname, bind, cnt, vals, logc = st.rprev, st.rnext, st.byname, st.bind, st.cnt, st.vals,
    self.logc
  local queue, cmd_deactivate = st.queue, cmd.deactivate or noop
  return function(_, name, kind, v)
    local code, ok = 8, true  -- L_EVENT[kind], and kind == "done"
    if kind ~= "done" then
      code, ok = L_EVENT[kind], false
      if not code then error("algebra: unknown event kind '" .. tostring(kind) .. "'", 2) end
      v = nil
    end
    local at = self.logi
    if at < 0 then  -- busy
      queue[#queue + 1] = { name, kind, v }
      return nil
    end
    local byname, rprev, rnext, parent, op = byname, rprev, rnext, parent, op  -- registers, not upvalues
    local id = byname[name]
    if not id then
      log(self, L_IGNORED[kind], name)
      return false
    end
    self.logi = -1 - at  -- busy
    local p, nx = rprev[id], rnext[id]
    rnext[p], rprev[nx] = nx, p
    byname[name] = nil
    at = at + 1  -- log: "event A done", and "-A[l]" for a labelled leaf
    logc[at & LOG_MASK] = id * 16 + code
    local lb = labels[id]
    if lb then cmd_deactivate(name, lb) end
    while true do
      p = parent[id]
      if p == 0 then
        if ok then self.st, self.value = "done", v else self.st, self.value = "aborted", nil end
        break
      end
      local o = op[p]
      if o == SEQ then
        local i = cidx[id]
        if ok and i < nk[p] then
          ok, at = start_node(kids[p][i + 1], bind[p], at)
          if ok then break end
        end
      elseif o == PAR then
        if ok then
          local t = vals[p]
          t[cidx[id]] = v
          local left = cnt[p] - 1
          cnt[p] = left
          if left > 0 then break end
          v, vals[p] = t, nil  -- handed up: the next start makes a new list
        else
          at = abort_range(p, at)
        end
      elseif o == DIS then
        at = abort_range(p, at)
      elseif o == COND then
        if ok and cidx[id] == 1 then
          ok, at = start_node(kids[p][2], v, at)
          if ok then break end
        end
      else  -- REC: P done -> Q bound to P's value; Q done -> a new iteration of P with the outer binding
        if ok then
          local ks = kids[p]
          if cidx[id] == 1 then ok, at = start_node(ks[2], v, at) else ok, at = start_node(ks[1], bind[p], at) end
          if ok then break end
        end
        v = nil
      end
      if not ok then v = nil end
      id = p
    end
    self.logi = at
    if queue[1] then self:_drain() end
    return true
  end
end

--- A new run of `expr` (an expression object, or text to parse: then nil, err on bad text).
function M.new(expr, commands)
  if type(expr) == "string" then
    local e, err = M.parse(expr)
    if not e then return nil, err end
    expr = e
  end
  if type(expr) ~= "table" or not expr.c then error("algebra.new: expected an expression from algebra.parse", 2) end
  commands = commands or {}
  local c = expr.c
  local self = setmetatable({
    expr = expr, c = c, st = "idle", value = nil,
    bind = {}, cnt = {}, vals = {}, rprev = { [0] = 0 }, rnext = { [0] = 0 }, byname = {},
    draining = false, queue = {}, logi = 0, logc = {}, logv = {},
  }, Run)
  local abort_range = make_abort(self, c, self.rprev, self.rnext, self.byname, commands)
  local start_node = make_start(self, c, self, commands, abort_range)
  self._start, self._abort = start_node, abort_range
  self.event = make_event(self, c, self, commands, start_node, abort_range)
  return self
end

--- Starts the expression (SEMANTICS.md §3). `init` (optional) is the value bound for the whole expression:
--- every leaf outside a ':' / ':;' right operand starts with it. Returns true if running afterwards.
--- A finished run may be started again.
function Run:start(init)
  if self.st == "running" then error("algebra: run:start() while the expression is running", 2) end
  self.st, self.value = "running", nil
  local ok, at = self.logi, nil
  self.logi = -1 - ok  -- busy
  ok, at = self._start(1, init, ok)
  self.logi = at
  if not ok then self.st = "aborted" end
  self:_drain()
  return self.st == "running"
end

-- Aborts every running leaf of a running, idle run: it ends ABORTED.
local function abort_all(self)
  local at = self.logi
  self.logi = -1 - at  -- busy
  at = self._abort(1, at)
  self.st, self.value = "aborted", nil
  self.logi = at
end

-- The queued events and aborts, in order (each through Run:event or abort_all); nothing if already draining
-- further up the stack.
function Run:_drain()
  if self.draining then return end
  self.draining = true
  local q = self.queue
  while q[1] and self.logi >= 0 do
    local e = table.remove(q, 1)
    if e[1] == "*" then
      if self.st == "running" then abort_all(self) end
    else
      self:event(e[1], e[2], e[3])
    end
  end
  self.draining = false
end

--- Run:event(name, kind, value) delivers an event of leaf `name`: kind "done" (with a value), "aborted" or
--- "error" (with a reason). Returns true if taken, false if stale (ignored and logged), nil if queued
--- (re-entrant call). Each run has its own (make_event).

--- Aborts the whole expression from outside. Returns true if it was running.
function Run:abort()
  if self.logi < 0 then  -- busy
    self.queue[#self.queue + 1] = { "*" }
    return nil
  end
  if self.st ~= "running" then return false end
  log(self, L_ABORT_ALL)
  abort_all(self)
  if self.queue[1] then self:_drain() end
  return true
end

-- Copies into the tables vals, cnt, bind (emptied first) the ',' values so far (each list copied), the ','
-- counters and the bindings of `s`.
local function copy_state(s, vals, cnt, bind)
  for id in pairs(vals) do vals[id] = nil end
  for id in pairs(cnt) do cnt[id] = nil end
  for id in pairs(bind) do bind[id] = nil end
  for id, t in pairs(s.vals) do
    local cp = { n = t.n }
    for i = 1, t.n do cp[i] = t[i] end
    vals[id] = cp
  end
  for id, k in pairs(s.cnt) do cnt[id] = k end
  for id, b in pairs(s.bind) do bind[id] = b end
end

--- A copy of the run's state, for dca.verify's exploration: { st =, value =, running = { leaf ids in start
--- order }, vals = { [par node id] = copy of its values so far }, cnt =, bind = } (node ids as in expr.c).
--- The log is not part of it. Not while an event is being processed.
function Run:snapshot()
  local running, rnext = {}, self.rnext
  local l, n = rnext[0], 0
  while l ~= 0 do
    n = n + 1
    running[n] = l
    l = rnext[l]
  end
  local s = { st = self.st, value = self.value, running = running, vals = {}, cnt = {}, bind = {} }
  copy_state(self, s.vals, s.cnt, s.bind)
  return s
end

--- Puts back a state taken by snapshot() (of a run of the same expression). The snapshot stays usable.
function Run:restore(s)
  local names, rprev, rnext, byname = self.c.name, self.rprev, self.rnext, self.byname
  for nm in pairs(byname) do byname[nm] = nil end
  local prev = 0
  for _, l in ipairs(s.running) do
    rprev[l], rnext[prev] = prev, l
    byname[names[l]] = l
    prev = l
  end
  rnext[prev], rprev[0] = 0, prev
  copy_state(s, self.vals, self.cnt, self.bind)
  self.st, self.value = s.st, s.value
end

--- "idle" | "running" | "done" | "aborted", and the value when "done".
function Run:status()
  return self.st, self.value
end

local function leaf_text(c, id)
  local lb = c.label[id]
  return lb and (c.name[id] .. "[" .. lb .. "]") or c.name[id]
end

--- The leaves running now, in start order ("Name" or "Name[label]").
function Run:running()
  local out, c = {}, self.c
  local rnext = self.rnext
  local l = rnext[0]
  while l ~= 0 do
    out[#out + 1] = leaf_text(c, l)
    l = rnext[l]
  end
  return out
end

--- True if this run has the leaf process `name` running now.
function Run:is_running(name)
  return self.byname[name] ~= nil
end

--- The expression's own text (layout kept) with each running leaf marked by mark(text) (default: *text*).
function Run:render(mark)
  mark = mark or function(s) return "*" .. s .. "*" end
  local byname, text = self.byname, self.expr.text
  local out, at = {}, 1
  for _, nd in ipairs(self.expr.leaves) do
    if byname[nd.name] == nd.id then
      out[#out + 1] = ssub(text, at, nd.pos - 1)
      out[#out + 1] = mark(ssub(text, nd.pos, nd.stop))
      at = nd.stop + 1
    end
  end
  out[#out + 1] = ssub(text, at)
  return concat(out)
end

local function show(v)
  if type(v) == "string" then return sformat("%q", v) end
  return tostring(v)
end

-- The text of one log entry, with the label switch it implies for a labelled leaf ("+A[l]" before its start,
-- "-A[l]" after its abort or its event): appended to out.
local KIND_OF = { [8] = "done", [9] = "aborted", [10] = "error", [11] = "done", [12] = "aborted", [13] = "error" }
local function log_lines(out, c, code, v)
  local k, a = code & 15, code >> 4
  if k == L_START then
    if c.label[a] then out[#out + 1] = "+" .. leaf_text(c, a) end
    out[#out + 1] = "start " .. leaf_text(c, a) .. (v ~= nil and (" init=" .. show(v)) or "")
  elseif k == L_ABORT or L_EVENT[KIND_OF[k]] == k then
    out[#out + 1] = k == L_ABORT and ("abort " .. c.name[a]) or ("event " .. c.name[a] .. " " .. KIND_OF[k])
    if c.label[a] then out[#out + 1] = "-" .. leaf_text(c, a) end
  elseif KIND_OF[k] then out[#out + 1] = "ignored " .. tostring(v) .. " " .. KIND_OF[k]
  elseif k == L_CONFLICT then out[#out + 1] = "conflict " .. c.name[a] .. " (already running)"
  else out[#out + 1] = "abort (external)" end
end

--- The latest log entries (at most 256), oldest first, as text:
--- "start A", "start A[l] init=5", "abort A", "+A[l]", "-A[l]", "event A done", "ignored A done",
--- "conflict A (already running)", "abort (external)".
function Run:log()
  local lines, c, logc, logv = {}, self.c, self.logc, self.logv
  local n = self.logi
  if n < 0 then n = -1 - n end  -- called by a command: the entries before its event
  for i = math.max(1, n - LOG_SIZE + 1), n do
    log_lines(lines, c, logc[i & LOG_MASK], logv[i & LOG_MASK])
  end
  -- an entry may give two lines: the latest 256
  local out, first = {}, math.max(1, #lines - LOG_SIZE + 1)
  for j = first, #lines do out[#out + 1] = lines[j] end
  return out
end

return M
