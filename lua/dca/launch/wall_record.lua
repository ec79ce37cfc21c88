-- dca.launch.wall_record: `dca run FILE --record FILE.mcap` on the wall clock (with --driver, or without --sim:
-- docs/recording.md, "Recording a wall-clock run"). No world writes it: the run does, in its own process
-- (core.mcap_writer), with log times on the wall clock (CLOCK_REALTIME, ns):
--   /dca/events       each line the run says, {line, path, state} as in a simulated run's recording
--   /dca/log          each line a process wrote to its stderr, {path, line}
--   /dca/rt/<path>    per leaf on a real-time thread (an rt { } setting; the path's dots as slashes), its figures
--                     there as its node's `stats` gives them (host/node.h, rt): runs, overruns, missed periods,
--                     the wake latency's and execution time's n, p50/p99/p99.9/max and histogram buckets
--                     ([upper edge us, count], those that hold runs), dropped samples, the thread's id and its
--                     allocations, locks and page faults; every PERIOD seconds while the run runs and once at
--                     its end (before the tree stops). Every field counts since the thread started.
--
--   local wr = require "dca.launch.wall_record"
--   local rec, err = wr.open(file, spec, request)   -- request(msg, cb): a console request (as the monitor's)
--   rec:line(line, output)     -- a line said (output: the path of the process that wrote it to its stderr)
--   rec:start_polling()        -- the figures every PERIOD seconds from now on
--   rec:poll(k)                -- the figures of every such leaf now; k() once all are written (bounded)
--   rec:finish() --> "FILE: N messages on K channels (/topic n, ...), C chunks" | nil, err
local core = require "dca.core"

local M = {}

local ipairs, tostring, tonumber, type, sformat = ipairs, tostring, tonumber, type, string.format

--- Seconds between two polls of the real-time figures.
M.PERIOD = 1

-- The run's lines as the recordings hold them (sim/recorder.cpp writes the same for simulated runs), also what
-- Foxglove gets live (dca.launch.live).
local EVENTS_SCHEMA = [[{"type":"object","title":"/dca/events","properties":{"line":{"type":"string"},]] ..
  [["path":{"type":"string"},"state":{"type":"string"}}}]]
local LOG_SCHEMA = [[{"type":"object","title":"/dca/log","properties":{"path":{"type":"string"},]] ..
  [["line":{"type":"string"}}}]]
M.EVENTS_SCHEMA, M.LOG_SCHEMA = EVENTS_SCHEMA, LOG_SCHEMA

--- A line of the run as its channel's message: "/dca/events", {line, path, state} (a transition's path and word,
--- else ""), or, for a line process `output` wrote to its stderr ("PATH: text"), "/dca/log", {path, line}.
--- --> topic, schema name, schema, JSON text
function M.line_message(line, output)
  line = tostring(line)
  if output then
    return "/dca/log", "dca/log", LOG_SCHEMA,
      core.json_encode({ path = tostring(output), line = line:sub(#tostring(output) + 3) })
  end
  local path, word = line:match("^(%S+): (%a+)")
  return "/dca/events", "dca/events", EVENTS_SCHEMA, core.json_encode({ line = line, path = path or "", state = word or "" })
end

-- The JSON Schema of a /dca/rt/<path> channel.
local function rt_schema(topic)
  local hist = [[{"type":"object","properties":{"n":{"type":"integer"},"p50_us":{"type":"number"},]] ..
    [["p99_us":{"type":"number"},"p999_us":{"type":"number"},"max_us":{"type":"number"},]] ..
    [["buckets":{"type":"array","description":"[upper edge in us, count] of each bucket that holds runs",]] ..
    [["items":{"type":"array","items":{"type":"number"},"minItems":2,"maxItems":2}}}}]]
  return sformat([[{"type":"object","title":"%s","description":"a leaf's figures on its real-time thread, ]] ..
    [[counted since the thread started (docs/time.md, Real time)","properties":{"path":{"type":"string"},]] ..
    [["runs":{"type":"integer"},"overruns":{"type":"integer"},"missed":{"type":"integer"},]] ..
    [["period_s":{"type":"number"},"wake":%s,"exec":%s,"dropped":{"type":"integer"},]] ..
    [["thread":{"type":"integer"},"contract":{"type":"object","properties":{"allocations":{"type":"integer"},]] ..
    [["locks":{"type":"integer"},"page_faults":{"type":"integer"}}}}}]], topic, hist, hist)
end

--- The topic of leaf `path`'s figures: /dca/rt/main/arm/servo.
function M.topic(path) return "/dca/rt/" .. tostring(path):gsub("%.", "/") end

--- The leaves of `spec` with an rt setting (docs/time.md, "Real time"), in tree order.
function M.rt_leaves(spec)
  local out = {}
  require("dca.supervisor.spec").walk(spec, function(n)
    if n.kind == "leaf" and type(n.rt) == "table" and ((tonumber(n.rt.priority) or 0) > 0 or
        (tonumber(n.rt.cpu) or -1) >= 0) then
      out[#out + 1] = n.path
    end
  end)
  return out
end

local Rec = {}
Rec.__index = Rec

--- The recording FILE created. --> rec | nil, err
function M.open(file, spec, request)
  local w, err = core.mcap_writer(file)
  if not w then return nil, err end
  return setmetatable({ w = w, file = file, request = request, leaves = M.rt_leaves(spec), channels = {} }, Rec)
end

-- The id of `topic`'s channel, added at its first message.
function Rec:_channel(topic, schema_name, schema)
  local id = self.channels[topic]
  if not id then
    id = self.w:channel(topic, schema_name, schema)
    self.channels[topic] = id
  end
  return id
end

function Rec:line(line, output)
  if self.finished then return end
  local topic, schema_name, schema, text = M.line_message(line, output)
  self.w:write(self:_channel(topic, schema_name, schema), text)
end

-- One leaf's figures written (a reply without them, or none, writes nothing).
function Rec:_figures(path, r)
  if self.finished or type(r) ~= "table" or r.type == "error" or type(r.rt) ~= "table" then return end
  local f = r.rt
  f.path = path
  local text = core.json_encode(f)
  if not text then return end
  text = text:gsub('"buckets":{}', '"buckets":[]')  -- (no runs yet: an empty table encodes as an object)
  local topic = M.topic(path)
  self.w:write(self:_channel(topic, topic:sub(2), rt_schema(topic)), text)
end

function Rec:poll(k)
  k = k or function() end
  local left, timer = #self.leaves, nil
  if left == 0 then k() return end
  local function over()
    if not timer then return end  -- (called back already)
    timer:cancel()
    timer = nil
    k()
  end
  -- bounded: a leaf that does not answer within 5 s is left out of this poll
  timer = core.after(5, over)
  for _, path in ipairs(self.leaves) do
    self.request({ type = "stats", leaf = path }, function(r)
      self:_figures(path, r)
      left = left - 1
      if left == 0 then over() end
    end)
  end
end

function Rec:start_polling()
  if #self.leaves == 0 or self.timer then return end
  self.timer = core.every(M.PERIOD, function() if not self.polling then
    self.polling = true
    self:poll(function() self.polling = false end)
  end end)
end

function Rec:finish()
  if self.timer then self.timer:cancel() self.timer = nil end
  if self.finished then return nil, "already finished" end
  self.finished = true
  local st, err = self.w:finish()
  if not st then return nil, err end
  local parts = {}
  for i, c in ipairs(st.channels) do parts[i] = c[1] .. " " .. tostring(c[2]) end
  return sformat("%s: %d messages on %d channels (%s), %d chunks", self.file, st.messages, #st.channels,
    table.concat(parts, ", "), st.chunks)
end

return M
