-- dca.trace: the trace of a run in simulated time (`dca run --trace FILE`, ARCHITECTURE.md "Time"), and the
-- first divergence of two. One line per fact, sorted by tick (ns), then by text:
--   T_NS D PATH.PORT n=COUNT digest=FNV value=LATEST   an output wrote at this tick (the world's and every node's)
--   T_NS S PATH +SET | -SET                            a connection set switched at this leaf (its source)
--   T_NS P PATH NAME=VALUE                             a live parameter of the leaf changed (taken by the
--                                                      node before this tick: its MainCalc here sees it)
--   T_NS E PATH events=N                               the leaf's done/aborted events so far
--   T_NS L PATH                                        the leaf's node was lost (did not answer its advance)
--   T_NS T LINE                                        a supervisor's transition line at the event's time
--                                                      (a pid in it written "(pid)": it differs from run to run)
-- The clock master (the world) writes D, S, P, E and L lines as the rounds end; the run adds the T lines and
-- merges both, so two runs of the same seed give the same file, byte for byte, whatever the load.
--
--   trace.merge(world_file, t_lines, out_file, last) --> true | nil, err (t_lines: { {ns, text} ... }; the
--                                                lines after tick `last`, the root's outcome, are left out)
--   trace.diff(file_a, file_b)                 --> nil (identical) | text of the first divergence, or nil, err
--   trace.diff_recordings(mcap_a, mcap_b)      --> nil, text (identical) | text of the first difference, or
--                                                false, err: the channels both MCAP recordings hold (ports and
--                                                world signals; not the run's lines) compared message by
--                                                message before the earlier run's end (its outcome's tick,
--                                                whose writes race the stop; docs/recording.md, "Replay")
local M = {}

local sformat, tonumber, ipairs = string.format, tonumber, ipairs

local function read_lines(file)
  local f, err = io.open(file, "r")
  if not f then return nil, err end
  local text, rerr = f:read("a")  -- (a directory opens, then reads nil and the reason: never raises)
  f:close()
  if not text then return nil, sformat("%s: %s", file, tostring(rerr)) end
  -- (a last line without its newline gets one: an unanchored "([^\n]+)$" to find it costs the square of the
  -- lines' length per line, 15 s on a door run's 6 MB trace)
  if text ~= "" and text:sub(-1) ~= "\n" then text = text .. "\n" end
  local lines = {}
  for l in text:gmatch("([^\n]*)\n") do lines[#lines + 1] = l end
  return lines
end

local function split(line)
  local t, rest = line:match("^(%d+) (.*)$")
  return tonumber(t) or -1, rest or line
end

--- Writes the sorted union of the world's trace and the transition lines, up to tick `last` (ns; nil: all).
function M.merge(world_file, t_lines, out_file, last)
  local lines, err = read_lines(world_file)
  if not lines then return nil, err end
  -- (a process id is no part of a run: a restart's line names its new pid, which differs from run to run)
  for _, e in ipairs(t_lines) do lines[#lines + 1] = sformat("%d T %s", e[1], (e[2]:gsub("%(pid %d+%)", "(pid)"))) end
  local keyed = {}
  for _, l in ipairs(lines) do
    local t, rest = split(l)
    if not last or t <= last then keyed[#keyed + 1] = { t = t, rest = rest, line = l } end
  end
  table.sort(keyed, function(a, b)
    if a.t ~= b.t then return a.t < b.t end
    return a.rest < b.rest
  end)
  local f, ferr = io.open(out_file, "w")
  if not f then return nil, ferr end
  for _, k in ipairs(keyed) do f:write(k.line, "\n") end
  f:close()
  return true
end

-- "D main.x.Out n=3 digest=... value=..." --> kind, who, fields
local function parts(rest)
  local kind, who, what = rest:match("^(%u) (%S+) ?(.*)$")
  return kind or "?", who or rest, what or ""
end

-- A side of a divergence: its line, "(end of trace)" past its last, or an unparsable line said as such.
local function show(line, t, rest)
  if line == nil then return "(end of trace)" end
  if t < 0 then return "(not a trace line) " .. line end
  return rest
end

--- The first line where the two traces differ, told as tick, process, port and both values.
function M.diff(file_a, file_b)
  local a, aerr = read_lines(file_a)
  if not a then return nil, aerr end
  local b, berr = read_lines(file_b)
  if not b then return nil, berr end
  for i = 1, math.max(#a, #b) do
    if a[i] ~= b[i] then
      local ta, ra = split(a[i] or "")
      local tb, rb = split(b[i] or "")
      if not a[i] then ta = -1 end
      if not b[i] then tb = -1 end
      local t = (ta >= 0 and tb >= 0) and math.min(ta, tb) or math.max(ta, tb)
      local ka, wa = parts(ra)
      local _, wb = parts(rb)
      local who = (wa == wb or not a[i]) and wb or (not b[i] and wa) or (wa .. " / " .. wb)
      return sformat("first divergence at line %d, tick %.9f s (%d ns), %s %s:\n  %s: %s\n  %s: %s", i,
        t / 1e9, t, ka == "D" and "port" or "process", who, file_a, show(a[i], ta, ra), file_b, show(b[i], tb, rb))
    end
  end
  return nil
end

-- The tick of the run's outcome in recording `rec` (its root's "DONE" or "ABORTED" line on /dca/events), or
-- past its last message. The writes of that tick race the run's stop, so they are not compared.
local function end_of(rec)
  local last = 0
  for _, m in ipairs(rec.messages) do
    local ch = rec.channels[m.channel]
    if ch and ch.topic == "/dca/events" and (m.data:find('"state":"DONE"', 1, true) or
                                             m.data:find('"state":"ABORTED"', 1, true)) then
      return m.t
    end
    if m.t >= last then last = m.t + 1 end
  end
  return last
end

-- The channels of recording `rec` by topic: { [topic] = { {t, data}, ... } }, the lines' channels left out, the
-- messages before tick `before` only.
local SKIPPED = { ["/dca/events"] = true, ["/dca/log"] = true, ["/dca/world/signals"] = true }
local function by_topic(rec, before)
  local out = {}
  for _, m in ipairs(rec.messages) do
    local topic = rec.channels[m.channel] and rec.channels[m.channel].topic
    if topic and not SKIPPED[topic] and m.t < before then
      local list = out[topic] or {}
      out[topic] = list
      list[#list + 1] = m
    end
  end
  return out
end

-- The first difference of two lists of messages: its time (ns), index, or nil.
local function first_difference(a, b)
  for i = 1, math.max(#a, #b) do
    local x, y = a[i], b[i]
    if not x or not y or x.t ~= y.t or x.data ~= y.data then
      return (x and y) and math.min(x.t, y.t) or (x or y).t, i
    end
  end
end

local function show_message(m)
  if not m then return "(no more messages)" end
  return sformat("%s at %.9f s", m.data, m.t / 1e9)
end

--- The first message where recordings `file_a` and `file_b` differ (see the header).
function M.diff_recordings(file_a, file_b)
  local core = require "dca.core"
  local ra, aerr = core.mcap_read(file_a)
  if not ra then return false, sformat("%s: %s", file_a, tostring(aerr)) end
  local rb, berr = core.mcap_read(file_b)
  if not rb then return false, sformat("%s: %s", file_b, tostring(berr)) end
  local before = math.min(end_of(ra), end_of(rb))
  local a, b = by_topic(ra, before), by_topic(rb, before)
  local topics, best, n = {}, nil, 0
  for topic in pairs(a) do if b[topic] then topics[#topics + 1] = topic end end
  table.sort(topics)
  for _, topic in ipairs(topics) do
    n = n + #a[topic]
    local t, i = first_difference(a[topic], b[topic])
    if t and (not best or t < best.t) then best = { t = t, i = i, topic = topic } end
  end
  if not best then
    return nil, sformat("identical: %s and %s (%d messages on %d channels compared, before the run's end at %.9f s)",
      file_a, file_b, n, #topics, before / 1e9)
  end
  return sformat("first difference at tick %.9f s (%d ns), message %d of %s:\n  %s: %s\n  %s: %s", best.t / 1e9,
    best.t, best.i, best.topic, file_a, show_message(a[best.topic][best.i]), file_b,
    show_message(b[best.topic][best.i]))
end

return M
