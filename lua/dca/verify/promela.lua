-- dca.verify.promela: the expression model in Promela, for a second opinion from spin (`dca check --verify
-- --promela`; tests/lua/verify/promela_test.lua runs spin on it and compares its verdicts with dca's).
--
-- Written from SEMANTICS.md, not from dca.algebra: each group's expression becomes straight-line Promela code
-- (the start of a node, what its parent does when it ends), each operand's possible events (from the same
-- operand behaviours dca.verify explores with) a guarded choice in one loop. Each reachable verdict is a
-- marker statement on its own line; spin's full search lists the markers it never reached ("unreached in
-- init"), so one run of spin gives every verdict: the ends (DONE with which operand's value, ABORTED by which
-- operand's abort or fault), a stuck state (nothing can happen and the expression has not ended: an invalid
-- end state in spin's terms) and each property's violation.
--
--   local model = promela.model({ { key = "door", expr = expr, operands = operands, props = list } ... })
--   -- operands as explored with faults; spin runs each expression with and without them (a fault event is
--   -- guarded by the bit `faults`), the verdicts without under key .. ":nofaults".
--   -- model.text: the Promela source; model.markers[line] = { key, verdict } ("done:hit", "aborted:servo",
--   --   "error:servo", "done:{}" (a ',' value), "stuck", "violated:<property text>")
--   local reached = promela.spin(model, dir)     -- { [key] = { [verdict] = true } } | nil, error
--   promela.verdicts(r)                          -- the same set, from a dca.verify group result
local M = {}

local ipairs, pairs, sformat, concat, tostring = ipairs, pairs, string.format, table.concat, tostring

local LEAF, PAR, SEQ, DIS, COND, REC = 0, 1, 2, 3, 4, 5
local TUPLE = 255

-- A code writer: lines with indentation; marker lines remember their verdict.
local function writer()
  local w = { lines = {}, markers = {}, depth = 1 }
  function w.put(s) w.lines[#w.lines + 1] = string.rep("  ", w.depth) .. s end
  -- the options of an `if` that mark a verdict when `cond` holds: one marker line for runs with faults, one
  -- for runs without (key .. ":nofaults")
  function w.marks(cond, key, verdict)
    w.put(":: faults && " .. cond .. " -> mark = 1")
    w.markers[#w.lines] = { key = key, verdict = verdict }
    w.put(":: !faults && " .. cond .. " -> mark = 1")
    w.markers[#w.lines] = { key = key .. ":nofaults", verdict = verdict }
  end
  return w
end

-- The property monitors' code at a leaf's start, end and abort (flags are bytes f<k>; a violation sets the
-- sticky bit p<k>, which a loop option then marks: the steps themselves are d_steps, without markers).
local function prop_hooks(props, names)
  local h = { start = {}, stop = {}, done = {}, state = {}, step = {} }
  for k, p in ipairs(props or {}) do
    local f = "f" .. k
    local function add(t, n, code) t[n] = t[n] or {} t[n][#t[n] + 1] = { code = code, prop = p } end
    if p.kind == "starts_after_done" then
      h.step[#h.step + 1] = { k = k, prop = p }
      add(h.done, p.b.text, f .. " = 1")
      add(h.start, p.a.text, "check:" .. k .. ":" .. f .. " == 0")
      add(h.start, p.b.text, f .. " = 0")
    elseif p.kind == "ends_before_start" then
      h.step[#h.step + 1] = { k = k, prop = p }
      add(h.start, p.a.text, f .. " = 0")
      add(h.stop, p.a.text, f .. " = 1")
      add(h.start, p.b.text, "check:" .. k .. ":" .. f .. " == 0")
    elseif p.kind == "runs_while" or p.kind == "exclusive" then
      h.state[#h.state + 1] = p
    end
  end
  h.names = names
  return h
end

local function leaf_ids(c, name)
  local out = {}
  for id = 1, c.n do if c.op[id] == LEAF and c.name[id] == name then out[#out + 1] = id end end
  return out
end

-- Promela for a state property's violation: a condition over st[] (any occurrence of a name running).
local function running_cond(c, name)
  local parts = {}
  for _, id in ipairs(leaf_ids(c, name)) do parts[#parts + 1] = "st[" .. id .. "] != 0" end
  if #parts == 0 then return "false" end
  return "(" .. concat(parts, " || ") .. ")"
end

local function state_violation(c, p, operands)
  if p.kind == "exclusive" then
    local parts = {}
    for _, n in ipairs(p.names) do parts[#parts + 1] = running_cond(c, n.text) end
    return concat(parts, " && ")
  end
  local others = {}
  if p.any then
    for name in pairs(operands) do if name ~= p.a.text then others[#others + 1] = running_cond(c, name) end end
  else
    others[1] = running_cond(c, p.b.text)
  end
  if #others == 0 then return "false" end
  return "!" .. running_cond(c, p.a.text) .. " && (" .. concat(others, " || ") .. ")"
end

-- Hooks of one kind for a name: plain assignments, and checks that set a violation bit.
local function run_hooks(w, _, list)
  for _, hk in ipairs(list or {}) do
    local k, cond = hk.code:match("^check:(%d+):(.*)$")
    if cond then
      w.put(sformat("if :: %s -> p%s = 1 :: else -> skip fi;", cond, k))
    else
      w.put(hk.code .. ";")
    end
  end
end

local gen_start, gen_end

gen_start = function(w, g, id)
  local c = g.c
  local o = c.op[id]
  if o == LEAF then
    w.put("st[" .. id .. "] = 1;")
    run_hooks(w, g.key, g.hooks.start[c.name[id]])
  elseif o == PAR or o == DIS then
    if o == PAR then w.put(sformat("dca_left[%d] = %d;", id, c.nk[id])) end
    for _, k in ipairs(c.kids[id]) do gen_start(w, g, k) end
  else
    gen_start(w, g, c.kids[id][1])
  end
end

-- Abort of every running leaf below id.
local function gen_abort(w, g, id)
  local c = g.c
  for l = id, c.last[id] do
    if c.op[l] == LEAF then
      for _, hk in ipairs(g.hooks.stop[c.name[l]] or {}) do
        w.put(sformat("if :: st[%d] != 0 -> %s :: else -> skip fi;", l, hk.code))
      end
      w.put("st[" .. l .. "] = 0;")
    end
  end
end

gen_end = function(w, g, id, ok)
  local c = g.c
  local p = c.parent[id]
  if p == 0 then
    w.put(ok and "res = 1;" or "res = 2;")
    return
  end
  local o, i = c.op[p], c.cidx[id]
  if o == SEQ then
    if ok and i < c.nk[p] then return gen_start(w, g, c.kids[p][i + 1]) end
    return gen_end(w, g, p, ok)
  elseif o == PAR then
    if not ok then
      gen_abort(w, g, p)
      return gen_end(w, g, p, false)
    end
    w.put(sformat("dca_left[%d] = dca_left[%d] - 1;", p, p))
    w.put("if")
    w.put(sformat(":: dca_left[%d] == 0 ->", p))
    w.depth = w.depth + 1
    w.put("val = " .. TUPLE .. ";")
    gen_end(w, g, p, true)
    w.depth = w.depth - 1
    w.put(":: else -> skip")
    w.put("fi;")
  elseif o == DIS then
    gen_abort(w, g, p)
    return gen_end(w, g, p, ok)
  elseif o == COND then
    if ok and i == 1 then return gen_start(w, g, c.kids[p][2]) end
    return gen_end(w, g, p, ok)
  else  -- REC
    if ok then return gen_start(w, g, c.kids[p][i == 1 and 2 or 1]) end
    return gen_end(w, g, p, false)
  end
end

-- The loop of one expression's events; `g` = { key, expr, operands, props, index }.
-- One option of the event loop: `guard`, then the step as a d_step (after `pre`, the nondeterministic choice
-- of the abort's reason, when there is one).
local function gen_step(w, g, id, guard, pre, ok)
  local c = g.c
  local name = c.name[id]
  w.put(sformat(":: %s -> %s", guard, pre and "atomic {" or "d_step {"))
  w.depth = w.depth + 1
  if pre then
    w.put(pre)
    w.put("d_step {")
  end
  w.put(sformat("st[%d] = 0;", id))
  run_hooks(w, g.key, g.hooks.stop[name])
  if ok then
    w.put("val = " .. g.vals[name] .. ";")
    run_hooks(w, g.key, g.hooks.done[name])
  end
  gen_end(w, g, id, ok)
  if pre then w.put("}") end
  w.depth = w.depth - 1
  w.put("}")
end

-- The loop's options for every event of every leaf: DONE; ABORTED or a fault (one option, the reason chosen
-- first: the same code follows). A group operand that can get stuck has an option to do so (st 2: it still
-- runs, and only a fault can end it).
local function gen_events(w, g)
  local c = g.c
  for id = 1, c.n do
    if c.op[id] == LEAF then
      local name = c.name[id]
      local vi = g.vals[name]
      local aborts, faults, stuck = false, false, false
      for _, ev in ipairs(g.operands[name].events) do
        if ev.kind == "done" then gen_step(w, g, id, sformat("st[%d] == 1", id), nil, true)
        elseif ev.kind == "stuck" then stuck = true
        elseif ev.fault then faults = true
        else aborts = true end
      end
      if stuck then
        w.put(sformat(":: st[%d] == 1 -> st[%d] = 2", id, id))
        gen_step(w, g, id, sformat("faults && st[%d] == 2", id), sformat("why = %d;", vi * 4 + 1), false)
      end
      if aborts and faults then
        gen_step(w, g, id, sformat("st[%d] == 1", id),
                 sformat("if :: why = %d :: faults -> why = %d fi;", vi * 4, vi * 4 + 1), false)
      elseif aborts or faults then
        gen_step(w, g, id, sformat("%sst[%d] == 1", faults and "faults && " or "", id),
                 sformat("why = %d;", vi * 4 + (faults and 1 or 0)), false)
      end
    end
  end
end

-- One expression: its start, its loop, its verdict markers.
local function gen_expr(w, g)
  local c = g.c
  w.put(sformat("e%d: skip; /* %s */", g.index, g.key))
  w.put("d_step {")
  w.depth = w.depth + 1
  gen_start(w, g, 1)
  w.depth = w.depth - 1
  w.put("};")
  w.put("do")
  for k, p in ipairs(g.hooks.state) do
    w.put(sformat(":: res == 0 && s%d == 0 && %s -> atomic {", k, state_violation(c, p, g.operands)))
    w.put(sformat("  s%d = 1;", k))
    w.put("  if")
    w.marks("true", g.key, "violated:" .. p.text)
    w.put("  fi }")
  end
  for _, sp in ipairs(g.hooks.step) do
    w.put(sformat(":: p%d == 1 && q%d == 0 -> atomic {", sp.k, sp.k))
    w.put(sformat("  q%d = 1;", sp.k))
    w.put("  if")
    w.marks("true", g.key, "violated:" .. sp.prop.text)
    w.put("  fi }")
  end
  gen_events(w, g)
  w.put(":: res != 0 -> break")
  w.put(":: else -> break")
  w.put("od;")
  w.put("if")
  for _, name in ipairs(g.expr.names) do
    local vi = g.vals[name]
    w.marks(sformat("res == 1 && val == %d", vi), g.key, "done:" .. name)
    w.marks(sformat("res == 2 && why == %d", vi * 4), g.key, "aborted:" .. name)
    w.marks(sformat("res == 2 && why == %d", vi * 4 + 1), g.key, "error:" .. name)
  end
  w.marks(sformat("res == 1 && val == %d", TUPLE), g.key, "done:{}")
  w.marks("res == 0", g.key, "stuck")
  w.put("fi;")
  w.put("goto fin;")
end

--- The Promela model of a list of expressions { key, expr, operands, props } (spin explores each, one at a
--- time: the first step picks which). --> { text, markers }
function M.model(list)
  local w = writer()
  local maxn = 1
  local gs = {}
  for i, item in ipairs(list) do
    local c = item.expr.c
    if c.n > maxn then maxn = c.n end
    local vals = {}
    for k, name in ipairs(item.expr.names) do vals[name] = k end
    gs[i] = { key = item.key, expr = item.expr, c = c, operands = item.operands, index = i, vals = vals,
              hooks = prop_hooks(item.props, item.expr.names) }
  end
  local nflags = 0
  for _, item in ipairs(list) do if item.props and #item.props > nflags then nflags = #item.props end end
  local head = { "/* dca check --verify --promela: the expression model (SEMANTICS.md), one expression per run */",
                 sformat("byte st[%d];", maxn + 1), sformat("byte dca_left[%d];", maxn + 1),
                 "byte val, why, res, mark;", "bit faults;" }
  for k = 1, nflags do head[#head + 1] = "byte f" .. k .. ";" head[#head + 1] = "bit p" .. k .. ", q" .. k .. ";" end
  local nstate = 0
  for _, g in ipairs(gs) do if #g.hooks.state > nstate then nstate = #g.hooks.state end end
  for k = 1, nstate do head[#head + 1] = "bit s" .. k .. ";" end
  head[#head + 1] = "init {"
  w.put("if :: faults = 1 :: faults = 0 fi;")
  w.put("if")
  for i = 1, #gs do w.put(sformat(":: goto e%d", i)) end
  w.put("fi;")
  for _, g in ipairs(gs) do gen_expr(w, g) end
  w.put("fin: skip")
  local markers, offset = {}, #head
  for line, m in pairs(w.markers) do markers[line + offset] = m end
  local text = concat(head, "\n") .. "\n" .. concat(w.lines, "\n") .. "\n}\n"
  return { text = text, markers = markers, lines = #head + #w.lines + 1 }
end

--- The verdicts of a dca.verify group result r in the model's terms: { [verdict] = true }.
function M.verdicts(r)
  local out = {}
  for _, d in ipairs(r.done) do
    if d.value:sub(1, 1) == "{" then out["done:{}"] = true else out["done:" .. d.value:match("^[^(]+")] = true end
  end
  for _, k in ipairs(r.ends_by) do out[k] = true end
  if r.stuck[1] or r.until_stopped then out.stuck = true end
  for _, p in ipairs(r.props) do
    if not p.ok and not p.outcome then out["violated:" .. p.prop.text] = true end
  end
  return out
end

--- The model of every group of a dca.verify result (what `--promela` prints).
function M.system(result)
  local list = {}
  for _, r in ipairs(result.groups) do
    local ps = {}
    for _, p in ipairs(r.props) do if not p.outcome then ps[#ps + 1] = p.prop end end
    list[#list + 1] = { key = r.path, expr = r.node.process.actions.expr, operands = r.operands, props = ps }
  end
  return M.model(list).text
end

--- Runs spin on the model in directory `dir` (spin -a, cc, pan: a full search) and reads the markers it
--- reached. --> { [key] = { [verdict] = true } }, pan's output | nil, error
function M.spin(model, dir)
  if model.lines > 32000 then  -- spin keeps line numbers in 16 bits: markers past 32,767 would be misread
    return nil, "a model of more than 32,000 lines: give spin fewer expressions at once"
  end
  local f = assert(io.open(dir .. "/model.pml", "w"))
  f:write(model.text)
  f:close()
  -- clang compiles pan.c about twice as fast as gcc at -O0 (both are in scripts/setup's list)
  local cmd = "cd '" .. dir .. "' && rm -f pan && spin -a -o3 model.pml >spin.log 2>&1 && " ..
              "{ CC=cc; command -v clang >/dev/null && CC=clang; $CC -O0 -w -DSAFETY -DVECTORSZ=4096 " ..
              "-o pan pan.c >cc.log 2>&1; } && ./pan -m1000000 -w20 2>&1"
  local p = io.popen(cmd)
  local out = p:read("a")
  p:close()
  if not out:find("unreached in init", 1, true) and not out:find("State%-vector") then
    return nil, "spin failed: " .. out
  end
  local unreached = {}
  for line in out:gmatch("model%.pml:(%d+), state %d+, \"mark = 1\"") do unreached[tonumber(line)] = true end
  local reached = {}
  for line, m in pairs(model.markers) do
    if not unreached[line] then
      reached[m.key] = reached[m.key] or {}
      reached[m.key][m.verdict] = true
    end
  end
  return reached, out
end

return M
