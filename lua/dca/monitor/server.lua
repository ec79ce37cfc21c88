-- dca.monitor.server: the web monitor of a run: the page (lua/dca/monitor/page/), the `dca.monitor.v1`
-- WebSocket protocol and the model (dca.monitor.model) it sends, on a core.web_listen server (host/web).
--
--   local mon, err = require("dca.monitor.server").start{
--     addr = "127.0.0.1:0",            -- where to listen (default 127.0.0.1:0: a free port)
--     name = "main",                   -- the system shown in the title
--     root = "main",                   -- its root path (lines about other names are no processes)
--     mode = "live" | "replay",
--     request = function(msg, cb) end, -- a console request (net.CONSOLE: tree, inject, restart, repl, ...): the
--                                      -- same authenticated path as the REPL; cb(reply) with reply.type
--     world = function(msg, cb) end,   -- optional: a request to the world (status polled for the plots)
--     world_spec = SPEC,                -- the world's spec (its descriptor's topics are plotted; nil: the default)
--     model = m,                       -- optional: a model already filled (a replay: dca.monitor.replay)
--     series = { {id, name, fields, rows} },  -- optional: recorded signals, offered as topics; a page that
--                                      -- subscribes to one gets its rows whole ({type = "series", ...})
--     robot = { urdf, frames, topic },  -- optional: a URDF world's robot (mon:robot)
--     blackbox = function(why, cb) end, -- optional (dca run --blackbox): triggers the black box, cb(reply {t} | nil,
--                                      -- err); the page shows its button, {type = "command", cmd = "blackbox", why}
--   }
--   mon:url()                 --> "http://127.0.0.1:PORT/?token=..."
--   mon:line(line, t)         -- a line of the run at time t (seconds)
--   mon:on_page(fn)           -- fn() once, when the first page has connected (dca run --monitor-wait)
--   mon:robot{urdf, frames = {{parent, child}, ...}, topic}  -- the robot the pages draw in 3D from its URDF,
--                             -- its link frames the samples (live) or rows (replay) of `topic`
--   mon.model, mon.srv        -- the model (dca.monitor.model), the server (dca.WebServer: topics, publish)
--   mon:close([loop])       -- with the run's loop: the last delta reaches the pages first
--
-- Protocol (JSON text messages). Server -> page: {type = "hello", mode, name, version}, {type = "snapshot",
-- nodes, exprs, events, config, lines, topics, t}, {type = "delta", ...the same fields, only what changed},
-- coalesced every 50 ms; {type = "samples", topic, name, rows} (host/web); {type = "history", topic, rows} (every
-- topic's rows from its first, bounded and decimated by the server's hub, host/web/sample_history.h: sent before its
-- samples when a page subscribes, and at the run's end, mon:close(loop), of every topic the page did not subscribe
-- to); a topic is {id, name, fields, units? (one per field, or one for all: mon.topic_units), history? (the world's
-- status: the page follows it from the start)}; {type = "reply", id, ok, text};
-- {type = "robot", urdf, frames, topic} (a URDF world's, at open or when known).
-- Page -> server: {type = "subscribe", topic, rate}, {type = "command", id, cmd = "abort" | "restart" |
-- "event" | "config_set" | "estop" | "release" | "clock" | "blackbox", path, kind, value, key, what, speed, why}. A
-- snapshot or delta carries `clock` {t, running, speed, stepping}, the world's (polled with the plots' status). A
-- message that is not JSON, or not one of these, is answered
-- {type = "error", reason} and counted; the page's connection stays. The token allows these commands and no
-- more: nothing a page sends is evaluated as code (Lua evaluation needs the cluster key: dca repl).
local core = require "dca.core"
local model_mod = require "dca.monitor.model"

local M = {}

local ipairs, pairs, tostring, type, tonumber, sformat = ipairs, pairs, tostring, type, tonumber, string.format

--- The subprotocol of the monitor's page.
M.PROTOCOL = "dca.monitor.v1"
--- Seconds between deltas, tree refreshes and world polls.
M.FLUSH, M.TREE_PERIOD, M.WORLD_PERIOD = 0.05, 1.0, 0.05

-- The page's files: path -> file name, content type.
local PAGES = {
  ["/"] = { "index.html", "text/html; charset=utf-8" },
  ["/monitor.js"] = { "monitor.js", "text/javascript; charset=utf-8" },
  ["/monitor.css"] = { "monitor.css", "text/css; charset=utf-8" },
  ["/robot3d.js"] = { "robot3d.js", "text/javascript; charset=utf-8" },
  ["/plot.js"] = { "plot.js", "text/javascript; charset=utf-8" },
}

-- The 3D view's modules (robot3d.js): three.js and urdf-loader from page/3d/node_modules (scripts/setup, npm ci),
-- served as they are under /3d/node_modules/ (index.html's import map names them). Absent: the page says so.
local VENDOR = {
  "three/build/three.module.js", "three/build/three.core.js",
  "three/examples/jsm/loaders/STLLoader.js", "three/examples/jsm/loaders/ColladaLoader.js",
  "three/examples/jsm/loaders/TGALoader.js", "three/examples/jsm/loaders/collada/ColladaParser.js",
  "three/examples/jsm/loaders/collada/ColladaComposer.js",
  "urdf-loader/src/URDFLoader.js", "urdf-loader/src/URDFClasses.js",
}

local Mon = {}
Mon.__index = Mon

-- Reads a page file. --> text | nil, err
local function read_page(name)
  local path = core.lua_dir .. "/dca/monitor/page/" .. name
  local f, err = io.open(path, "rb")
  if not f then return nil, err end
  local text = f:read("a")
  f:close()
  return text
end

--- Starts the monitor's server. --> monitor | nil, err
function M.start(o)
  local srv, err = core.web_listen(o.addr or "127.0.0.1:0", { max_connections = 64 })
  if not srv then return nil, "--monitor: " .. tostring(err) end
  for path, p in pairs(PAGES) do
    local text, perr = read_page(p[1])
    if not text then srv:close() return nil, "the monitor's page: " .. tostring(perr) end
    srv:page(path, text, p[2], true)
  end
  for _, f in ipairs(VENDOR) do
    local text = read_page("3d/node_modules/" .. f)
    if text then srv:page("/3d/node_modules/" .. f, text, "text/javascript; charset=utf-8", true) end
  end
  local self = setmetatable({ o = o, srv = srv, model = o.model or model_mod.new(o.root), pages = {}, page_waiters = {},
                              commands = 0, errors = 0, robot_info = o.robot, followed = {} }, Mon)
  self.topics_seen = self:_topics_key(self:_topics())
  if o.series then
    self.series_by_id = {}
    for _, t in ipairs(o.series) do self.series_by_id[t.id] = t end
  end
  srv:protocol(M.PROTOCOL, {
    open = function(c) self:_open(c) end,
    message = function(c, text) self:_message(c, text) end,
    close = function(c) self.pages[c] = nil end,
  })
  self.timer = core.every(M.FLUSH, function() self:_flush() end)
  if o.request then self:_refresh_tree() self.tree_timer = core.every(M.TREE_PERIOD, function() self:_refresh_tree() end) end
  if o.world then self.world_timer = core.every(M.WORLD_PERIOD, function() self:_poll_world() end) end
  if o.request then self:_watch_config() end
  return self
end

function Mon:url() return sformat("http://%s/?token=%s", self.srv:address(), self.srv:token()) end

-- Sends table `t` as JSON to page `c` (droppable ones may be left out for a slow page).
local function send(c, t, droppable)
  local text = core.json_encode(t)
  if text then c:send(text, droppable) end
end

--- The units of a topic's `n` fields from its port's manifest text: "m/s, m/s, rad/s" for 3 fields gives one
--- each; any other text (one unit, or a description such as "0 open, 1 close") is every field's: { text }.
function M.field_units(text, n)
  text = type(text) == "string" and text or ""
  local parts = {}
  for p in (text .. ","):gmatch("%s*([^,]-)%s*,") do parts[#parts + 1] = p end
  if n > 1 and #parts == n then return parts end
  return { text }
end

-- The live sample topics, for the page: with each field's unit when known (mon.topic_units(name) --> the port's
-- manifest text, set by whoever made the topics: dca.launch.live) and whether the page follows it from the start.
function Mon:_topics()
  local out = {}
  for _, t in ipairs(self.srv:topics()) do  -- (not the streams of messages: the run's lines are the page's own)
    if not t.stream then
      local units = self.topic_units and self.topic_units(t.name) or (self.world_units or {})[t.name]
      out[#out + 1] = { id = t.id, name = t.name, fields = t.fields, history = self.followed[t.id] or nil,
                        units = units and M.field_units(units, #(t.fields or {})) or nil }
    end
  end
  for _, t in ipairs(self.o.series or {}) do
    local units = self.topic_units and self.topic_units(t.name)
    out[#out + 1] = { id = t.id, name = t.name, fields = t.fields,
                      units = units and M.field_units(units, #(t.fields or {})) or nil }
  end
  return out
end

function Mon:_open(c)
  self:_flush()  -- what is pending goes to the pages already open: the snapshot holds it for this one
  self.pages[c] = {}  -- the topics it subscribed to
  send(c, { type = "hello", mode = self.o.mode or "live", name = self.o.name or "", version = 1,
            blackbox = self.o.blackbox ~= nil or nil })
  local snap = self.model:snapshot()
  snap.type, snap.topics = "snapshot", self:_topics()
  send(c, snap)
  if self.robot_info then send(c, self:_robot_message()) end
  if self.o.on_open then self.o.on_open(self, c) end
  if self.o.request then self:_refresh_tree() end  -- hosts and types now, not at the next period
  local waiters = self.page_waiters
  self.page_waiters = {}
  for _, fn in ipairs(waiters) do fn() end
end

function Mon:_robot_message()
  local r = self.robot_info
  return { type = "robot", urdf = r.urdf, frames = r.frames, topic = r.topic }
end

--- The robot the pages draw (see the header), told to the pages open now and to those that open later.
function Mon:robot(r)
  if not (type(r) == "table" and r.urdf and r.frames and r.topic) then return end
  self.robot_info = r
  for c in pairs(self.pages) do send(c, self:_robot_message()) end
end

--- fn() once, as soon as a page is connected (now, if one is).
function Mon:on_page(fn)
  if next(self.pages) then fn() return end
  self.page_waiters[#self.page_waiters + 1] = fn
end

-- The ids of `topics` as one text (a change of it is sent to the pages).
function Mon:_topics_key(topics)
  local ids = {}
  for _, t in ipairs(topics) do ids[#ids + 1] = tostring(t.id) .. (t.units and "u" or "") .. (t.history and "h" or "") end
  return table.concat(ids, ",")
end

-- The deltas since the last flush, to every page; new topics too.
function Mon:_flush()
  if not next(self.pages) then self.model:take_delta() return end  -- a new page gets a snapshot
  local d = self.model:take_delta()
  local topics = self:_topics()
  local key = self:_topics_key(topics)
  if key ~= self.topics_seen then
    self.topics_seen = key
    d = d or { t = self.model.t }
    d.topics = topics
  end
  if not d then return end
  d.type = "delta"
  local text = core.json_encode(d)
  for c in pairs(self.pages) do c:send(text) end
end

-- The tree again (hosts, states, expressions), through the console request: once at the start, then every
-- TREE_PERIOD while a page is open (the lines keep the states between; the tree catches what no line says).
-- The figures of every leaf on a real-time thread (docs/time.md, "Real time"), with each tree refresh: one stats
-- request per such leaf, through the console's path; a leaf on simulated time answers without them.
function Mon:_ask_rt()
  for _, path in ipairs(self.model:rt_leaves()) do
    self.o.request({ type = "stats", leaf = path }, function(r)
      if r and r.type ~= "error" and type(r.rt) == "table" then self.model:rt(path, r.rt) end
    end)
  end
end

function Mon:_refresh_tree()
  if self.tree_pending or (self.tree_once and not next(self.pages)) then return end
  self.tree_once = true
  self.tree_pending = true
  self.o.request({ type = "tree" }, function(r)
    self.tree_pending = false
    if r and r.type ~= "error" and type(r.tree) == "table" then self.model:tree(r.tree) end
    self:_ask_rt()
  end)
end

-- The configuration: its keys now (config.list) and every change after (config.watch's lines), through the
-- console's commands like any REPL.
function Mon:_watch_config()
  self.o.request({ type = "repl", line = "return config.list()" }, function(r)
    if not (r and type(r.output) == "string") then return end
    for key, text in r.output:gmatch("([^\n=]-) = ([^\n]*)") do self.model:set_config(key, text, "") end
    self.o.request({ type = "repl", line = "config.watch()" }, function() end)
  end)
end

-- The world's status, published as the topics its descriptor names (dca.worlds: e.g. /world/base from the
-- status's base_pose), the plots' live source beside the port taps.
function Mon:_poll_world()
  if self.world_pending or not next(self.pages) then return end
  self.world_pending = true
  self.o.world({ type = "status" }, function(r)
    self.world_pending = false
    if not (r and tonumber(r.t)) then return end
    self.model:clock(r)  -- the header's clock and the timeline's now: the world's time, paused or not
    local srv, t = self.srv, tonumber(r.t)
    if t == self.world_t then return end
    self.world_t = t
    self.world_topics = self.world_topics or {}
    local fed = {}  -- topics a tap feeds (dca.launch.live: the world's signals): the status is not published there
    for _, x in ipairs(srv:topics()) do fed[x.name] = x.id end
    for i, d in ipairs(require("dca.worlds").descriptor(self.o.world_spec).topics) do
      local values, fields = {}, d.fields
      if fed[d.topic] and fed[d.topic] ~= self.world_topics[i] then fields = nil
      elseif d.value then fields, values[1] = { "value[0]" }, tonumber(r[d.value]) or 0
      elseif d.array and not fields and type(r[d.array]) == "table" then
        fields = {}  -- every item, named as a port's {"value": [...]} (and its recorded channel) names them
        for k = 1, #r[d.array] do fields[k] = "value[" .. (k - 1) .. "]" end
      end
      for k, f in ipairs(d.value and {} or fields or {}) do
        local v = d.array and type(r[d.array]) == "table" and r[d.array][k] or r[f]
        values[k] = tonumber(v) or 0
      end
      if fields and (not d.array or type(r[d.array]) == "table") then
        self.world_topics[i] = self.world_topics[i] or srv:topic(d.topic, fields, d.units)
        self.world_units = self.world_units or {}
        self.world_units[d.topic] = d.units
        srv:publish(self.world_topics[i], t, values)
        self.followed[self.world_topics[i]] = true
      end
    end
  end)
end

--- A line of the run at time `t` (seconds); "[sim 1.000] " or "[  1.000] " prefixes give the time.
function Mon:line(line, t)
  line = tostring(line)
  local st, rest = line:match("^%[sim%s+([%d.]+)%] (.*)$")
  if not st then st, rest = line:match("^%[%s*([%d.]+)%] (.*)$") end
  if st then line, t = rest, t or tonumber(st) end
  local key, text, origin = line:match("^config: (.-) = (.*) %(written on (.-)%)$")
  if key then self.model:set_config(key, text, origin) end
  local known = #self.model.order
  self.model:line(line, t)
  -- a process the tree did not have yet (the start, a reload): the tree again for its host and type
  if #self.model.order > known and self.o.request and next(self.pages) then self:_refresh_tree() end
end

-- A value typed in the page for config_set, read by dca.literal (never evaluated; a plain word is a string), as
-- the supervisor's config_set request. --> msg | nil, err
local function config_set(key, text)
  local k, v = require("dca.config").parse_assignment(tostring(key) .. "=" .. tostring(text))
  if not k then return nil, v end
  return { type = "config_set", key = k, value = v }
end

-- A page's command as a console request. --> msg | nil, err
local function command_request(m)
  local path = m.path ~= nil and tostring(m.path) or nil
  if m.cmd == "restart" and path then return { type = "restart", path = path } end
  if m.cmd == "abort" and path then
    return { type = "inject", path = path, msg = { type = "aborted", reason = "aborted from the monitor" } }
  end
  if m.cmd == "abort" then return { type = "repl", line = "return abort()" } end
  if m.cmd == "event" and path and (m.kind == "done" or m.kind == "aborted") then
    local msg = { type = m.kind }
    if m.kind == "done" then msg.value = m.value else msg.reason = tostring(m.value or "from the monitor") end
    return { type = "inject", path = path, msg = msg }
  end
  if m.cmd == "config_set" and m.key then return config_set(m.key, m.value) end
  -- a fleet (docs/supervision.md, "A fleet"): an instance of a template added on a host, or an instance removed
  if m.cmd == "add_child" and path and m.host ~= nil then return { type = "add_child", path = path, host = tostring(m.host) } end
  if m.cmd == "remove_child" and path then return { type = "remove_child", path = path } end
  -- the robot's emergency stop (docs/safety.md): the console's requests, the monitor as their source
  if m.cmd == "estop" then return { type = "estop", source = "monitor" } end
  if m.cmd == "release" then return { type = "release", what = m.what ~= nil and tostring(m.what) or nil, source = "monitor" } end
  -- the simulated clock (docs/time.md "Pace"): pause, go, step, step_event, speed (0.1 to 10, "max"), checked by
  -- the supervisor's clock request as the REPL's are
  if m.cmd == "clock" then
    return { type = "clock", what = tostring(m.what), speed = type(m.speed) == "number" and m.speed or tostring(m.speed) }
  end
  return nil, "unknown command " .. tostring(m.cmd)
end

-- The page's black box button (docs/recording.md, "Black box"): the file names `monitor: WHY` (default "page").
function Mon:_blackbox(c, id, m)
  if not self.o.blackbox then
    send(c, { type = "reply", id = id, ok = false, text = "this run has no black box (dca run --blackbox)" })
    return
  end
  self.commands = self.commands + 1
  local why = "monitor: " .. (m.why ~= nil and tostring(m.why):sub(1, 200) or "page")
  self.o.blackbox(why, function(r, err)
    local text = r and r.t and sformat("black box triggered (%s) at %.3f s", why, r.t) or tostring(err or "no answer")
    if c:is_open() then send(c, { type = "reply", id = id, ok = (r and r.t) ~= nil, text = text }) end
  end)
end

function Mon:_command(c, m)
  local id = tonumber(m.id) or 0
  if m.cmd == "blackbox" then return self:_blackbox(c, id, m) end
  local req, err = self.o.request and command_request(m)
  if not self.o.request then err = "this monitor replays a recording: nothing to change" end
  if not req then send(c, { type = "reply", id = id, ok = false, text = tostring(err) }) return end
  self.commands = self.commands + 1
  self.o.request(req, function(r)
    local ok = r and r.type ~= "error"
    local text = r and (r.reason or r.text or r.output or r.note) or "no answer"
    if c:is_open() then send(c, { type = "reply", id = id, ok = ok and true or false, text = tostring(text or "") }) end
  end)
end

-- A page's topic number: an integer a topic can have (1e308, -1 or 2.5 are none). --> id | nil
local function topic_id(v)
  local id = math.tointeger(tonumber(v))
  if id and id >= 0 and id < 2147483648 then return id end
end

function Mon:_message(c, text)
  local m, err = core.json_decode(text)
  if type(m) ~= "table" then
    self.errors = self.errors + 1
    send(c, { type = "error", reason = "not JSON: " .. tostring(err) })
    return
  end
  if m.type == "subscribe" and self.series_by_id and self.series_by_id[m.topic] then
    -- a recorded signal: its rows, once (the page plots them up to its slider)
    local t = self.series_by_id[m.topic]
    send(c, { type = "series", topic = t.id, name = t.name, fields = t.fields, rows = t.rows })
  elseif m.type == "subscribe" and topic_id(m.topic) then
    local id, rate = topic_id(m.topic), tonumber(m.rate) or 30
    if rate ~= rate or rate <= 0 then rate = 30 end  -- (NaN or none: the default)
    -- its history from its first sample (the server's hub keeps every topic's), then its samples
    local h = self.srv:history(id)
    if h then c:send(h) end
    if self.pages[c] then self.pages[c][id] = true end
    c:subscribe(id, math.min(rate, 200))
    if self.on_subscribe then self.on_subscribe(id) end  -- a port's tap (dca.launch.live)
  elseif m.type == "subscribe" then
    self.errors = self.errors + 1
    send(c, { type = "error", reason = "subscribe: topic " .. tostring(m.topic) .. " is not a topic's number" })
  elseif m.type == "command" then
    self:_command(c, m)
  elseif self.o.on_message and self.o.on_message(self, c, m) then
    return
  else
    self.errors = self.errors + 1
    send(c, { type = "error", reason = "unknown message type " .. tostring(m.type) })
  end
end

-- The run's end: every topic's history to each page that did not subscribe to it, so that after the end, with the
-- server gone, a topic picked on the page shows the run from its start. Droppable: a page that cannot take them all
-- (a system of thousands of ports) loses some, counted, rather than its connection.
function Mon:_histories()
  for c, subs in pairs(self.pages) do
    for _, t in ipairs(self.srv:topics()) do
      local h = not subs[t.id] and not t.stream and self.srv:history(t.id)
      if h then c:send(h, true) end
    end
  end
end

--- Stops the timers and the server (the pages see the connection close). With `loop` (a loop that has stopped:
--- the end of a run), what is pending is sent first and the loop runs until the pages have it (at most 1 s).
function Mon:close(loop)
  if loop then
    self:_flush()
    self.srv:flush_samples()  -- each topic's last sample, held back by its rate: the plots reach the end
    self:_histories()
    loop:run_until(function()
      for c in pairs(self.pages) do if c:is_open() and c:stats().queued_bytes > 0 then return false end end
      return true
    end, 1)
  end
  for _, k in ipairs({ "timer", "tree_timer", "world_timer" }) do if self[k] then self[k]:cancel() end end
  self.srv:close()
end

return M
