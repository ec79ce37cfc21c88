-- dca.monitor.replay: a recorded run (MCAP, `dca run --sim ... --record FILE.mcap`) as the monitor's model and
-- signals: the lines of /dca/events at their simulated times (the transitions among them are the events the
-- page replays with its slider), and every other JSON channel (the world's signals) as a series of rows.
--
--   local replay = require "dca.monitor.replay"
--   local rec, err = replay.load(FILE, spec)   -- spec: the system's spec (dca.load.spec), for hosts, types and
--                                              -- expressions; nil: the tree from the recorded paths alone
--   rec.model    -- dca.monitor.model with the tree and every line
--   rec.series   -- { { id = "r1", name = "/world/door", fields = { ... }, rows = { { t, v1, ... }, ... } }, ... }
--                -- (rows: read from the file's chunks when indexed, at each access)
--   rec.robot    -- a URDF world's: { urdf (/robot_description), frames = { {parent, child}, ... }, topic = the
--                -- series id of its link frames (foxglove.FrameTransforms: rows { t, x y z qx qy qz qw per frame }) }
local core = require "dca.core"
local model_mod = require "dca.monitor.model"
local spec_mod = require "dca.supervisor.spec"

local M = {}

local ipairs, pairs, type, tonumber, tostring, max = ipairs, pairs, type, tonumber, tostring, math.max

--- Rows kept per signal: longer ones are thinned evenly (the page plots them whole).
M.MAX_ROWS = 5000

--- The tree of a spec in Sup:tree's shape (no states: a replay starts from nothing).
function M.spec_tree(spec)
  local node = { path = spec.path, kind = "group", type = spec.type, host = spec.host, expr = spec.expr,
                 children = {} }
  for i, c in ipairs(spec.children) do
    if c.kind == "group" then node.children[i] = M.spec_tree(c.spec)
    else node.children[i] = { path = c.path, kind = "leaf", type = c.type, host = c.host } end
  end
  return node
end

-- The field names of a JSON object, in the order written; an array field is one name per element
-- ("value[0]", ... : a port's {"value": [...]}, as the live topics name them).
local function fields_of(text, v)
  local out = {}
  for k in text:gmatch('"([^"]+)"%s*:') do
    if type(v[k]) == "table" then
      for i = 1, #v[k] do out[#out + 1] = { k, i, k .. "[" .. (i - 1) .. "]" } end
    elseif v[k] ~= nil then
      out[#out + 1] = { k, nil, k }
    end
  end
  return out
end

-- A channel's messages as rows { t, v1, ... } of its numeric fields (thinned to MAX_ROWS): `n` messages, called
-- back in order by each(fn).
local function series(id, topic, n, each)
  local fields, rows = nil, {}
  local step = max(1, n / M.MAX_ROWS)
  local i, next_i = 0, 1
  each(function(m)
    i = i + 1
    if i >= next_i then
      next_i = next_i + step
      local v = core.json_decode(m.data)
      if type(v) == "table" then
        fields = fields or fields_of(m.data, v)
        local row = { m.t / 1e9 }
        for k, f in ipairs(fields) do
          local x = v[f[1]]
          if f[2] then x = type(x) == "table" and x[f[2]] or nil end
          row[k + 1] = tonumber(x) or 0
        end
        rows[#rows + 1] = row
      end
    end
  end)
  local names = {}
  for k, f in ipairs(fields or {}) do names[k] = f[3] end
  return { id = "r" .. id, name = topic, fields = names, rows = rows }
end

-- A channel of foxglove.FrameTransforms as a series of rows { t, x, y, z, qx, qy, qz, qw, ... } in the order of
-- the first message's transforms (the world's frames); --> the series, the frames { {parent, child}, ... }.
local function frames_series(id, topic, n, each)
  local frames, rows, index = nil, {}, {}
  local step = max(1, n / M.MAX_ROWS)
  local i, next_i = 0, 1
  each(function(m)
    i = i + 1
    local v = i >= next_i and core.json_decode(m.data)
    if type(v) == "table" and type(v.transforms) == "table" then
      next_i = next_i + step
      if not frames then
        frames = {}
        for k, x in ipairs(v.transforms) do
          frames[k] = { tostring(x.parent_frame_id), tostring(x.child_frame_id) }
          index[tostring(x.child_frame_id)] = k
        end
      end
      local row = { m.t / 1e9 }
      for _, x in ipairs(v.transforms) do
        local k = index[tostring(x.child_frame_id)]
        local p, q = type(x.translation) == "table" and x.translation or {}, type(x.rotation) == "table" and x.rotation or {}
        if k then
          local at = 1 + 7 * (k - 1)
          row[at + 1], row[at + 2], row[at + 3] = tonumber(p.x) or 0, tonumber(p.y) or 0, tonumber(p.z) or 0
          row[at + 4], row[at + 5], row[at + 6], row[at + 7] = tonumber(q.x) or 0, tonumber(q.y) or 0, tonumber(q.z) or 0,
            tonumber(q.w) or 1
        end
      end
      rows[#rows + 1] = row
    end
  end)
  local names = {}
  for k = 0, 7 * #(frames or {}) - 1 do names[#names + 1] = "value[" .. k .. "]" end
  return { id = "r" .. id, name = topic, fields = names, rows = rows }, frames or {}
end

-- The URDF of a /robot_description message ({"data": URDF}), or nil.
local function urdf_of(m)
  local v = m and core.json_decode(m.data)
  return type(v) == "table" and type(v.data) == "string" and v.data or nil
end

-- A file without a summary (core.mcap_index refuses it) read whole, at most 1 GiB, as one chunk of an index.
local function whole(file)
  local rec, err = core.mcap_read(file)
  if not rec then return nil, err end
  local counts, all = {}, {}
  for id in pairs(rec.channels) do all[id] = true end
  for _, m in ipairs(rec.messages) do counts[m.channel] = (counts[m.channel] or 0) + 1 end
  local sum = { channels = rec.channels, counts = counts, chunks = { { channels = all } } }
  return { summary = function() return sum end, chunk = function() return rec.messages end,
           chunks_read = function() return 1 end }
end

-- A channel's messages in file order (each_of(idx, sum, id)(fn)): its chunks read one at a time.
local function each_of(idx, sum, id)
  return function(fn)
    for i, c in ipairs(sum.chunks) do
      if c.channels[id] then
        local msgs, err = idx:chunk(i)
        if not msgs then  -- (the file changed or is damaged since it was opened: the rows so far)
          io.stderr:write("dca monitor: ", tostring(err), "\n")
          return
        end
        for _, msg in ipairs(msgs) do
          if msg.channel == id then fn(msg) end
        end
      end
    end
  end
end

-- Reads the chunks an opening needs: those of the lines (`events`, into model m) and the URDF (`desc`), and the
-- first of every other channel. --> { [channel] = its first message }, urdf | nil, err
local function opening(idx, sum, events, desc, m)
  local want, seen = {}, {}
  for i, c in ipairs(sum.chunks) do
    if c.channels[events] or (desc and c.channels[desc]) then want[i] = true end
    for id in pairs(c.channels) do
      if not seen[id] then seen[id], want[i] = true, true end
    end
  end
  local first, urdf = {}, nil
  for i = 1, #sum.chunks do
    local msgs, err = {}, nil
    if want[i] then msgs, err = idx:chunk(i) end
    if not msgs then return nil, err end
    for _, msg in ipairs(msgs) do
      if msg.channel == events then
        local v = core.json_decode(msg.data)
        if type(v) == "table" and v.line then
          if not m.root and v.path and v.path ~= "" then m.root = v.path:match("^[^.]+") end
          m:line(v.line, msg.t / 1e9)
        end
      elseif msg.channel == desc then
        urdf = urdf or urdf_of(msg)
      elseif not first[msg.channel] then
        first[msg.channel] = msg
      end
    end
  end
  return first, urdf
end

-- The series of channel `id` (its fields from its first message); its rows are read at each access of s.rows.
-- --> the series, its frames (a foxglove.FrameTransforms channel's) or nil
local function lazy_series(idx, sum, id, first)
  local ch, n = sum.channels[id], sum.counts[id]
  local make = ch.schema == "foxglove.FrameTransforms" and frames_series or series
  local s, frames = make(id, ch.topic, 1, function(fn) fn(first) end)
  s.rows = nil
  return setmetatable(s, { __index = function(_, k)
    if k ~= "rows" then return nil end
    if not n then  -- no statistics: counted first
      n = 0
      each_of(idx, sum, id)(function() n = n + 1 end)
    end
    return make(id, ch.topic, n, each_of(idx, sum, id)).rows
  end }), frames
end

--- Loads a recording through its summary (core.mcap_index): the chunks that hold the run's lines and
--- /robot_description, and the first chunk of each other channel (its fields). A series' rows are read when
--- asked for (s.rows: the channel's chunks, one at a time, each time), so a long recording is never held whole.
--- --> { model, series, root, robot, index } | nil, err
function M.load(file, spec)
  local idx = core.mcap_index(file)
  local err
  if not idx then idx, err = whole(file) end
  if not idx then return nil, err end
  local sum = idx:summary()
  local events, desc
  for id, ch in pairs(sum.channels) do
    if ch.topic == "/dca/events" then events = id elseif ch.topic == "/robot_description" then desc = id end
  end
  if not events then return nil, file .. ": no /dca/events channel (record with `dca run --sim WORLD --record`)" end
  local m = model_mod.new(spec and spec.path or nil)
  if spec then m:tree(M.spec_tree(spec), 0) end
  local first, urdf = opening(idx, sum, events, desc, m)
  if not first then return nil, urdf end
  local out, ids, robot = {}, {}, {}
  for id in pairs(first) do ids[#ids + 1] = id end
  table.sort(ids)
  for _, id in ipairs(ids) do
    local s, frames = lazy_series(idx, sum, id, first[id])
    if frames then robot.frames, robot.topic = frames, s.id end
    out[#out + 1] = s
  end
  robot.urdf = urdf
  m:take_delta()
  return { model = m, series = out, root = m.root, robot = (urdf and robot.topic) and robot or nil, index = idx }
end

return M
