-- dca.verify.report: the text of `dca check --verify`, and traces as events.
--
--   report.text(result, { file = "door_open.dca", traces = true })  --> the whole report
--   report.flatten(trace, prefix)  --> the leaf events of a group's trace: { path, kind, group, direct } ...
--                                      (kind: done | aborted | crashed | lost | stuck; direct: what a scenario
--                                      makes happen; group: the end of a group operand that follows from inner
--                                      events, or its getting stuck; after: a timer's seconds)
--   report.trace_lines(r, trace)   --> numbered lines: each event, and the starts and aborts it caused
local algebra = require "dca.algebra"
local explore = require "dca.verify.explore"

local M = {}

local ipairs, sformat, concat = ipairs, string.format, table.concat

local function kind_of(ev)
  if ev.kind == "done" then return "done" end
  if ev.kind == "error" then return "crashed" end
  if ev.kind == "stuck" then return "stuck" end
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
    out[#out + 1] = { path = path, kind = kind, group = ev.group, direct = not inner, value = ev.value,
                      after = ev.after, waiting = ev.waiting }
  end
  return out
end

local function event_text(e)
  if e.kind == "lost" then return e.path .. " lost (its supervisor or its host)" end
  if e.kind == "stuck" then return "-> " .. e.path .. " gets stuck: waits forever on " .. concat(e.waiting, ", ") end
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
    if s.ev.kind ~= "stuck" then run:event(s.name, s.ev.kind, s.ev.value) end
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
  if #r.done == 0 then
    out[#out + 1] = r.partial and "  unknown   whether it can end DONE (none found in the part explored)"
      or "  can never end DONE"
  end
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
  for _, l in ipairs(require("dca.verify.template").lines(r)) do out[#out + 1] = l end
  if r.stops_unknown then
    out[#out + 1] = "  unknown   whether it runs until it is stopped (it waits on a group explored in part)"
  elseif r.until_stopped then
    out[#out + 1] = "  runs until it is stopped: nothing in it ends by itself"
  elseif r.never_ends and r.partial then
    out[#out + 1] = "  unknown   whether it can end by itself (no end but by a fault found in the part explored)"
  elseif r.never_ends then
    out[#out + 1] = "  FINDING can never end by itself: only a fault can end it"
  end
end

-- The lines of a trace of group r, then the traces inside the groups below it (c.inner), in that order.
local function traced(r, c, out)
  for _, l in ipairs(M.trace_lines(r, c.trace)) do out[#out + 1] = l end
  for _, inner in ipairs(c.inner or {}) do
    out[#out + 1] = sformat("      then inside %s (process %s):", inner.path, inner.r.type)
    for _, l in ipairs(M.trace_lines(inner.r, inner.trace)) do out[#out + 1] = l end
  end
end

-- One writer per input (dca.verify.writers): two writers in one state, dead command paths, inputs that two
-- groups claim, and what a partial exploration leaves unknown.
local function writer_findings(r, out)
  for _, w in ipairs(r.writers or {}) do
    out[#out + 1] = sformat("  FINDING two writers on %s: %s and %s can write it in the same state", w.input, w.a, w.b)
    traced(r, w, out)
  end
  for _, d in ipairs(r.dead_paths or {}) do
    out[#out + 1] = d.set and sformat("  FINDING dead command path: %s (set %s) never reaches %s: never %s "
      .. "while its drive runs", d.path, d.set, d.input, d.hops > 1 and "all active together" or "active")
      or sformat("  FINDING dead actuator: %s never runs, so %s never reaches %s", d.actuator, d.path, d.input)
  end
  for _, c in ipairs(r.claims or {}) do
    out[#out + 1] = sformat("  FINDING %s is claimed by two groups: %s", c.input, c.text)
  end
  for _, u in ipairs(r.writers_unknown or {}) do out[#out + 1] = "  unknown   " .. u end
end

-- The findings of group r: stuck states, dead operands, conflicting connection sets, properties.
local function findings(r, out, traces)
  for k, s in ipairs(r.stuck) do
    if k > 3 then
      out[#out + 1] = sformat("  ... and %d more stuck states", #r.stuck - 3)
      break
    end
    local waits = {}
    for j, w in ipairs(s.waiting) do  -- a group operand stuck inside: where it waits
      local ev = s.inside and s.inside[w]
      waits[j] = ev and sformat("%s (stuck: %s.%s waits forever on %s)", w, r.path, w, concat(ev.waiting, ", ")) or w
    end
    out[#out + 1] = "  FINDING can get stuck: waits forever on " .. concat(waits, ", ") ..
      " (nothing running can end but by a fault)"
    for _, l in ipairs(M.trace_lines(r, s.trace)) do out[#out + 1] = l end
  end
  for _, s in ipairs(r.stuck_unknown or {}) do
    out[#out + 1] = "  unknown   whether it can get stuck waiting on " .. concat(s.waiting, ", ") ..
      " (a group it waits on was explored in part)"
  end
  for _, leaf in ipairs(r.dead) do
    out[#out + 1] = sformat(r.partial and "  unknown   whether %s (line %d, col %d) can start (not in the part explored)"
      or "  FINDING %s (line %d, col %d) can never start", leaf.label and
      (leaf.name .. "[" .. leaf.label .. "]") or leaf.name, leaf.line or 0, leaf.col or 0)
  end
  for _, c in ipairs(r.conflicts) do
    out[#out + 1] = sformat("  FINDING connection sets %s and %s can be active together: %s", c.a, c.b, c.why)
    traced(r, c, out)
  end
  writer_findings(r, out)
  for _, p in ipairs(r.props) do
    out[#out + 1] = (p.unknown and "  unknown   " or p.ok and "  holds     " or "  VIOLATED  ") .. p.prop.text ..
      (p.unknown and " (not proven: the exploration is partial)" or
       (p.never_starts and p.ok) and (" (vacuous: " .. p.prop.a.text .. " never starts)") or "")
    if p.writers then
      out[#out + 1] = sformat("    %s and %s can write it in the same state (the FINDING above has the trace)",
        p.writers.a, p.writers.b)
    elseif not p.ok and p.trace then
      out[#out + 1] = "    counter-example:"
      for _, l in ipairs(M.trace_lines(r, p.trace)) do out[#out + 1] = l end
    elseif not p.ok and p.outcome and not p.unknown then
      out[#out + 1] = p.never_starts and sformat("    %s never starts in any run of %s", p.prop.a.text, r.path)
        or ("    no run of " .. r.path .. " ends that way")
      if p.stuck then
        out[#out + 1] = sformat("    %s gets stuck waiting on %s:", p.stuck.r.path, concat(p.stuck.stuck.waiting, ", "))
        for _, l in ipairs(M.trace_lines(p.stuck.r, p.stuck.stuck.trace)) do out[#out + 1] = l end
      end
    end
  end
  if r.truncated then
    out[#out + 1] = sformat("  PARTIAL exploration stopped at the state limit (--max-states): %s explored, %s left " ..
      "unexplored; what was found holds, nothing else is proven", plural(r.states - r.unexplored, "state"),
      plural(r.unexplored, "state"))
  elseif r.partial then
    out[#out + 1] = "  PARTIAL a group below was explored only in part: what was found holds, nothing else is proven"
  end
  if not traces then return end
end

--- The whole report. opts: { file = name, traces = true (traces of the outcomes too) }. --> text, findings,
--- violated properties, unknown verdicts (a partial exploration's), groups explored only in part
function M.text(result, opts)
  opts = opts or {}
  local out = {}
  for _, r in ipairs(result.groups) do
    out[#out + 1] = sformat("%s (process %s): %s, %s", r.path, r.type, plural(r.states, "state"),
      plural(r.transitions, "transition"))
    outcomes(r, out, opts.traces)
    findings(r, out, opts.traces)
  end
  local nf, nv, nu, np = 0, 0, 0, 0
  for _, r in ipairs(result.groups) do
    nf = nf + #r.stuck + #r.conflicts + #(r.writers or {}) + #(r.dead_paths or {}) + #(r.claims or {})
    nu = nu + #(r.writers_unknown or {})
    if not r.partial then nf = nf + #r.dead + ((r.never_ends and not r.until_stopped) and 1 or 0) end
    if r.partial then np = np + 1 end
    for _, p in ipairs(r.props) do
      if p.unknown then nu = nu + 1 elseif not p.ok then nv = nv + 1 end
    end
  end
  local partial = np > 0 and sformat(", PARTIAL: %s explored in part (--max-states %d), %s",
    plural(np, "group"), result.max_states or 0, plural(nu, "verdict") .. " unknown") or ""
  out[#out + 1] = sformat("%s: %s: %s, %s explored, %s, %s, %s%s", opts.file or "system",
    np > 0 and "not fully verified" or "verified", plural(#result.groups, "group"), plural(result.states, "state"),
    plural(nf, "finding"), plural(nv, "violated property", "violated properties"),
    result.faults and "faults on" or "faults off (--no-faults)", partial)
  return concat(out, "\n") .. "\n", nf, nv, nu, np
end

return M
