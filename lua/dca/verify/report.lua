-- dca.verify.report: the text of `dca check --verify`, and traces as events.
--
--   report.text(result, { file = "door_open.dca", traces = true })  --> the whole report
--   report.flatten(trace, prefix)  --> the leaf events of a group's trace: { path, kind, group, direct } ...
--                                      (kind: done | aborted | crashed | lost; direct: what a scenario makes
--                                      happen; group: the end of a group operand that follows from inner events)
--   report.trace_lines(r, trace)   --> numbered lines: each event, and the starts and aborts it caused
local algebra = require "dca.algebra"
local explore = require "dca.verify.explore"

local M = {}

local ipairs, sformat, concat = ipairs, string.format, table.concat

local function kind_of(ev)
  if ev.kind == "done" then return "done" end
  if ev.kind == "error" then return "crashed" end
  return "aborted"
end

--- The leaf events of a trace of a group (steps { name, ev, pick }), names prefixed with `prefix`.
function M.flatten(trace, prefix, out)
  out = out or {}
  prefix = prefix or ""
  for _, s in ipairs(trace) do
    local ev, path = s.ev, prefix .. s.name
    local reason = ev.reasons and ev.reasons[s.pick or 1]
    local inner = ev.inner or (reason and reason.inner)
    if inner then M.flatten(inner, path .. ".", out) end
    local kind = kind_of(ev)
    if reason and reason.lost then kind = "lost" end
    out[#out + 1] = { path = path, kind = kind, group = ev.group, direct = not inner, value = ev.value }
  end
  return out
end

local function event_text(e)
  if e.kind == "lost" then return e.path .. " lost (its supervisor or its host)" end
  if e.group and not e.direct then return "-> " .. e.path .. " " .. e.kind end
  return e.path .. " " .. e.kind
end

--- Numbered lines for a trace of group r: the leaf events in order, each top-level one followed by what the
--- group's expression did (starts, aborts), replayed with dca.algebra.
function M.trace_lines(r, trace, indent)
  indent = indent or "      "
  local rec = explore.recorder()
  local run = algebra.new(r.node.process.actions.expr, rec.commands)
  run:start()
  local lines = {}
  local function commands()
    local parts = {}
    for _, c in ipairs(rec.cmds) do parts[#parts + 1] = c[1] .. " " .. c[2] end
    rec.reset()
    return concat(parts, ", ")
  end
  lines[1] = indent .. "   " .. commands()
  local n = 0
  for _, s in ipairs(trace) do
    local flat = M.flatten({ s }, "")
    for _, e in ipairs(flat) do
      n = n + 1
      lines[#lines + 1] = sformat("%s%2d. %s", indent, n, event_text(e))
    end
    run:event(s.name, s.ev.kind, s.ev.value)
    local cmds = commands()
    if cmds ~= "" then lines[#lines + 1] = indent .. "    => " .. cmds end
  end
  local st = run:status()
  if st ~= "running" then lines[#lines + 1] = indent .. "    => " .. r.path .. " ends " .. st:upper() end
  return lines
end

local function plural(n, one, many) return n == 1 and ("1 " .. one) or (n .. " " .. (many or one .. "s")) end

-- The outcome lines of group r.
local function outcomes(r, out, traces)
  for _, d in ipairs(r.done) do
    out[#out + 1] = "  can end DONE with " .. d.value
    if traces then for _, l in ipairs(M.trace_lines(r, d.trace)) do out[#out + 1] = l end end
  end
  if #r.done == 0 then out[#out + 1] = "  can never end DONE" end
  local faults = 0
  for _, a in ipairs(r.aborted) do
    if a.fault then faults = faults + 1
    else
      out[#out + 1] = "  can end ABORTED: " .. a.reason
      if traces then for _, l in ipairs(M.trace_lines(r, a.trace)) do out[#out + 1] = l end end
    end
  end
  if faults > 0 then
    out[#out + 1] = sformat("  can end ABORTED by a fault: %s", plural(faults, "crash or lost host", "crashes or lost hosts"))
  end
  if r.cycle then out[#out + 1] = "  can run for ever: its runs can come back to a state they were in (':;')" end
  if r.until_stopped then
    out[#out + 1] = "  runs until it is stopped: nothing in it ends by itself"
  elseif r.never_ends then
    out[#out + 1] = "  FINDING can never end by itself: only a fault can end it"
  end
end

-- The findings of group r: stuck states, dead operands, conflicting connection sets, properties.
local function findings(r, out, traces)
  for k, s in ipairs(r.stuck) do
    if k > 3 then
      out[#out + 1] = sformat("  ... and %d more stuck states", #r.stuck - 3)
      break
    end
    out[#out + 1] = "  FINDING can get stuck: waits forever on " .. concat(s.waiting, ", ") ..
      " (nothing running can end but by a fault)"
    for _, l in ipairs(M.trace_lines(r, s.trace)) do out[#out + 1] = l end
  end
  for _, leaf in ipairs(r.dead) do
    out[#out + 1] = sformat("  FINDING %s (line %d, col %d) can never start", leaf.label and
      (leaf.name .. "[" .. leaf.label .. "]") or leaf.name, leaf.line or 0, leaf.col or 0)
  end
  for _, c in ipairs(r.conflicts) do
    out[#out + 1] = sformat("  FINDING connection sets %s and %s can be active together: %s", c.a, c.b, c.why)
    for _, l in ipairs(M.trace_lines(r, c.trace)) do out[#out + 1] = l end
    for _, inner in ipairs(c.inner or {}) do
      out[#out + 1] = sformat("      then inside %s (process %s):", inner.path, inner.r.type)
      for _, l in ipairs(M.trace_lines(inner.r, inner.trace)) do out[#out + 1] = l end
    end
  end
  for _, p in ipairs(r.props) do
    out[#out + 1] = (p.ok and "  holds     " or "  VIOLATED  ") .. p.prop.text
    if not p.ok and p.trace then
      out[#out + 1] = "    counter-example:"
      for _, l in ipairs(M.trace_lines(r, p.trace)) do out[#out + 1] = l end
    elseif not p.ok and p.outcome then
      out[#out + 1] = "    no run of " .. r.path .. " ends that way"
      if p.stuck then
        out[#out + 1] = sformat("    %s gets stuck waiting on %s:", p.stuck.r.path, concat(p.stuck.stuck.waiting, ", "))
        for _, l in ipairs(M.trace_lines(p.stuck.r, p.stuck.stuck.trace)) do out[#out + 1] = l end
      end
    end
  end
  if r.truncated then out[#out + 1] = "  WARNING exploration stopped at the state limit: the results are partial" end
  if not traces then return end
end

--- The whole report. opts: { file = name, traces = true (traces of the outcomes too) }.
function M.text(result, opts)
  opts = opts or {}
  local out = {}
  for _, r in ipairs(result.groups) do
    out[#out + 1] = sformat("%s (process %s): %s, %s", r.path, r.type, plural(r.states, "state"),
      plural(r.transitions, "transition"))
    outcomes(r, out, opts.traces)
    findings(r, out, opts.traces)
  end
  local nf, nv = 0, 0
  for _, r in ipairs(result.groups) do
    nf = nf + #r.stuck + #r.dead + #r.conflicts + ((r.never_ends and not r.until_stopped) and 1 or 0)
    for _, p in ipairs(r.props) do if not p.ok then nv = nv + 1 end end
  end
  out[#out + 1] = sformat("%s: verified: %s, %s explored, %s, %s, %s%s", opts.file or "system",
    plural(#result.groups, "group"), plural(result.states, "state"), plural(nf, "finding"),
    plural(nv, "violated property", "violated properties"),
    result.faults and "faults on" or "faults off (--no-faults)", "")
  return concat(out, "\n") .. "\n", nf, nv
end

return M
