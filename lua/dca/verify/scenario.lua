-- dca.verify.scenario: a counter-example of `dca check --verify` as a scenario (`dca scenario FILE.lua`, see
-- dca.scenario) that makes the same run happen: the tree comes up, each leaf event of the trace is injected
-- (done, aborted) or caused (a crash: SIGSEGV; a lost group: its supervisor killed) once its process runs,
-- and the last step checks the state the counter-example ends in (which operands of its group run, which do
-- not) and that the violation is there. The leaves' own behaviours (a Counter's count) are switched off, so
-- only the trace drives the run, except the timers' (Timer, Deadline, with their seconds written in the file):
-- the trace's timer events are awaited, not injected, so a trace whose timers cannot end in its order fails.
--
--   local text, what = scenario.text(result, "door.dca", "main")   -- nil when there is no counter-example
--   local ok, err = scenario.write("cex.lua", result, "door.dca", "main")
local report = require "dca.verify.report"
local model = require "dca.lang.model"
local algebra = require "dca.algebra"
local verify = require "dca.verify"

local M = {}

local ipairs, sformat, concat = ipairs, string.format, table.concat

-- Every counter-example, in report order: violated properties, then stuck states, sets active together and
-- two writers of one input in one state.
-- --> { { r, cex = { trace, kind, text, prop | waiting | sets } } ... }
local function all(result)
  local out = {}
  for _, r in ipairs(result.groups) do
    for _, p in ipairs(r.props) do
      if not p.ok and p.trace then
        out[#out + 1] = { r = r, cex = { trace = p.trace, kind = p.prop.kind, text = p.prop.text, prop = p.prop } }
      elseif not p.ok and p.stuck then
        out[#out + 1] = { r = p.stuck.r, cex = { trace = p.stuck.stuck.trace, kind = "stuck",
          waiting = p.stuck.stuck.waiting, text = p.prop.text .. " is violated: " .. p.stuck.r.path .. " gets stuck" } }
      end
    end
  end
  for _, r in ipairs(result.groups) do
    for _, st in ipairs(r.stuck) do
      out[#out + 1] = { r = r, cex = { trace = st.trace, kind = "stuck", waiting = st.waiting,
                                       text = r.path .. " gets stuck waiting on " .. concat(st.waiting, ", ") } }
    end
    for _, c in ipairs(r.conflicts) do
      local p = c.pair
      local owners = { r.path .. "." .. p.a:match("^[^%[]+") }
      owners[2] = c.inner and (c.inner[#c.inner].path .. "." .. p.target:match("^[^%[]+")) or
        (r.path .. "." .. p.b:match("^[^%[]+"))
      out[#out + 1] = { r = r, cex = { trace = c.trace, inner = c.inner, kind = "conflict", owners = owners,
                                       text = c.why } }
    end
    for _, w in ipairs(r.writers or {}) do
      out[#out + 1] = { r = r, cex = { trace = w.trace, inner = w.inner, kind = "conflict", owners = w.running,
                                       text = w.why } }
    end
  end
  return out
end
M.all = all

-- The leaf events that bring group r's instance at r.path from the root's start to its own start.
local function lead_in(result, r)
  local out = {}
  local node = r.node
  local chain = {}
  while node.parent do
    table.insert(chain, 1, node)
    node = node.parent
  end
  for _, child in ipairs(chain) do
    local pr
    for _, g in ipairs(result.groups) do if g.type == child.parent.process.name then pr = g end end
    local trace = pr and pr.first_running[child.name]
    if trace then report.flatten(trace, child.parent.path .. ".", out) end
  end
  return out
end

local function q(s) return sformat("%q", s) end

-- The Lua lines of one event step (a timer's own end is awaited: its seconds, and a margin).
local function event_step(e)
  if e.group and not e.direct then return nil end
  local lines = { sformat("S.step(%q, function()", e.path .. " " .. e.kind) }
  lines[#lines + 1] = sformat("  sys:wait_state(%s, \"running\", 5)", q(e.path))
  if e.after and (e.kind == "done" or e.kind == "aborted") then
    lines[1] = sformat("S.step(%q, function()", e.path .. " " .. e.kind .. " (its own time: " .. e.after .. " s)")
    lines[#lines + 1] = sformat("  sys:wait(%s, function() return sys:state(%s) ~= \"running\" end, %s)",
      q(e.path .. " ends by itself"), q(e.path), e.after + 5)
    lines[#lines + 1] = sformat("  S.eq(sys:state(%s), %q, %q)", q(e.path), e.kind, e.path .. " ended by itself")
  elseif e.kind == "done" then
    lines[#lines + 1] = sformat("  sys:inject(%s, \"done\", %s)", q(e.path), q(tostring(e.value)))
  elseif e.kind == "aborted" then
    lines[#lines + 1] = sformat("  sys:inject(%s, \"aborted\", %s)", q(e.path), q("aborted (dca check --verify)"))
  elseif e.kind == "lost" then
    lines[#lines + 1] = sformat("  sys:kill(%s, \"KILL\")", q(e.path))
  else
    lines[#lines + 1] = sformat("  sys:kill(%s, \"SEGV\")", q(e.path))
  end
  lines[#lines + 1] = "end)"
  return concat(lines, "\n")
end

-- The state group r is in at the end of `trace` (replayed through its expression): each operand running or
-- not, as assertions.
local function final_state(r, trace, l)
  local run = algebra.new(r.node.process.actions.expr, {})
  run:start()
  for _, s in ipairs(trace) do
    if s.ev.kind ~= "stuck" then run:event(s.name, s.ev.kind, s.ev.value) end
  end
  if run:status() ~= "running" then return end
  l[#l + 1] = sformat("  S.eq(sys:state(%s), \"running\", %q)", q(r.path), r.path .. " still runs")
  for _, name in ipairs(r.node.process.actions.expr.names) do
    local path = r.path .. "." .. name
    if run:is_running(name) then l[#l + 1] = sformat("  S.eq(sys:state(%s), \"running\", %q)", q(path), name .. " runs")
    else l[#l + 1] = sformat("  S.ok(sys:state(%s) ~= \"running\", %q)", q(path), name .. " does not run") end
  end
end

-- The Lua lines of the last step: the state the trace ends in, and the violation is there.
local function check_step(r, cex)
  local base = r.path .. "."
  local l = { sformat("S.step(%q, function()", "the violation: " .. cex.text) }
  local k = cex.kind
  if k ~= "can_end" then final_state(r, cex.trace, l) end
  if k == "starts_after_done" or k == "ends_before_start" then
    local who = k == "starts_after_done" and cex.prop.a.text or cex.prop.b.text
    l[#l + 1] = sformat("  S.eq(sys:state(%s), \"running\", %q)", q(base .. who), who .. " has started")
  elseif k == "runs_while" then
    l[#l + 1] = sformat("  S.ok(sys:state(%s) ~= \"running\", %q)", q(base .. cex.prop.a.text),
      cex.prop.a.text .. " is not running")
  elseif k == "exclusive" then
    for _, n in ipairs(cex.prop.names) do
      l[#l + 1] = sformat("  S.eq(sys:state(%s), \"running\")", q(base .. n.text))
    end
  elseif k == "can_end" then  -- a 'cannot end' that fails: the run ends so
    l[#l + 1] = "  local out = sys:wait_outcome(5)"
    if cex.prop.how then l[#l + 1] = sformat("  S.eq(out.type, %q)", cex.prop.how) end
  elseif k == "conflict" then
    for _, path in ipairs(cex.owners) do l[#l + 1] = sformat("  S.eq(sys:state(%s), \"running\")", q(path)) end
  else  -- stuck (also a 'can end' that fails): nothing ends, however long it runs (an hour of simulated time
    -- in memory, 2 s (stretched to 28 s by dca.scenario.real.bound) on the real backend)
    l[#l + 1] = "  local ended, out = pcall(sys.wait_outcome, sys, S.backend == \"real\" and 2 or 3600)"
    l[#l + 1] = "  S.ok(not ended, \"no outcome: \" .. S.show(out))"
    for _, w in ipairs(cex.waiting or {}) do
      l[#l + 1] = sformat("  S.ok(sys:state(%s) == \"running\", %q)", q(base .. w), w .. " still runs")
    end
  end
  l[#l + 1] = "end)"
  return concat(l, "\n")
end

--- The scenario's text for the n-th counter-example of result (default the first), or nil when there is none.
function M.text(result, file, root, n)
  local pick = all(result)[n or 1]
  if not pick then return nil end
  local r, cex = pick.r, pick.cex
  local types, seen, world = {}, {}, false
  local timed = {}  -- a type stays on when every leaf of it is a timer the verifier knows the seconds of
  model.walk(result.root.node, function(n)
    if n.kind == "leaf" then timed[n.type] = timed[n.type] ~= false and verify.seconds(n) ~= nil end
  end)
  model.walk(result.root.node, function(n)
    if n.kind == "leaf" and not seen[n.type] and not timed[n.type] then
      seen[n.type] = true
      types[#types + 1] = n.type .. " = idle"
    end
    for _, list in ipairs(n.kind == "leaf" and n.manifest and { n.manifest.inputs or {}, n.manifest.outputs or {} } or {}) do
      for _, port in ipairs(list) do world = world or port.device ~= nil end
    end
  end)
  local out = {
    "-- The counter-example of `dca check --verify " .. file .. "`: " .. cex.text .. ".",
    "-- Replay: dca scenario THIS_FILE (each leaf event is injected once its process runs, a timer's awaited; in",
    "-- memory the other leaves' own behaviours are off, so only this trace drives the run; --backend real runs",
    "-- the real processes). The last step checks the state the trace ends in.",
    "local S = require \"dca.scenario\"",
    "local function idle() end",
    sformat("local opts = { root = %s, behave = { %s } }", q(root or "main"), concat(types, ", ")),
    -- a system with device ports runs, on the real backend, in the simulated world its robot lives in
    world and sformat("if S.backend == \"real\" then opts = { root = %s, sim = %s } end -- its world",
                      q(root or "main"), q(require("dca.worlds").resolve() or "")) or "-- (no device ports: no world)",
    sformat("local sys = S.system(%s, opts)", q(file)),
    "S.step(\"the tree comes up\", function() sys:up() end)",
    "S.step(\"run\", function() sys:run() end)",
  }
  for _, e in ipairs(lead_in(result, r)) do
    local s = event_step(e)
    if s then out[#out + 1] = s end
  end
  local events = report.flatten(cex.trace, r.path .. ".")
  for _, inner in ipairs(cex.inner or {}) do report.flatten(inner.trace, inner.path .. ".", events) end
  for _, e in ipairs(events) do
    local s = event_step(e)
    if s then out[#out + 1] = s end
  end
  out[#out + 1] = check_step(r, cex)
  out[#out + 1] = "return S.finish()"
  return concat(out, "\n") .. "\n", cex.text
end

--- Writes the scenario to `path`. --> what it shows | nil, error
function M.write(path, result, file, root)
  local text, what = M.text(result, file, root)
  if not text then return nil, "dca check --verify: no counter-example to write (every property holds, nothing is stuck)" end
  local f, err = io.open(path, "w")
  if not f then return nil, "dca check: cannot write " .. tostring(err) end
  f:write(text)
  f:close()
  return "the counter-example: " .. what
end

return M
