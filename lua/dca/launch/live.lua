-- dca.launch.live: the live samples of a run for its viewers (ARCHITECTURE.md "Taps"): every output of the tree,
-- and with --sim every signal of the world, is a topic of the monitor's server's live samples ("/main/door/hit/
-- Force", "/world/arm/q": the recordings' topics), tapped (host/tap.h) into a tap point of the root's process: all of
-- them before time starts (tap_all; the server's hub keeps each from t = 0), or with --monitor-taps picked when a
-- viewer first subscribes to it. The server also speaks the Foxglove WebSocket protocol (core.foxglove), so
-- Foxglove and Lichtblick connect to ws://ADDR/?token=T and plot them; the monitor's page subscribes to the same
-- topics (live:tap_topic). Foxglove's parameters (its Parameters panel) are the configuration repository's keys:
-- getParameters reads them on the root's host, setParameters writes them as the monitor's config_set does (through
-- the root), so a change reaches the running leaves whose live parameter reads that key (dca.supervisor.live).
--
--   local live, err = require("dca.launch.live").start(ctx, sup, srv, cb)
--       ctx: the start context (spec, hosts, key, sim), sup: the root supervisor, srv: the dca.WebServer;
--       cb(true) | cb(nil, err) once the topics are made (the world's signals asked of the world)
--   local live = require("dca.launch.live").attach(o, srv, request, cb)
--       the same for `dca monitor ADDR` (a console of a running root): o.daemon (where the tap point registers),
--       o.key, o.root (the root's path); the ports from the root's `ports`, each tap asked of the root as a
--       console request `tap {path, to}` (made through its tree: a restart makes it again), no world signals
--   live:tap_topic(topic, cb)  -- the tap of that topic, made once: cb(true) | cb(nil, err)
--   live:tap_all(k)            -- every port's and world signal's, before time starts (--monitor-taps all, the
--                              -- default in M.start): the server's hub keeps each from t = 0
--   live:tap_id(id, cb)        -- the same by the topic's id (the monitor's page subscribes by id)
--   live:units(topic)          -- the units its port's manifest gives ("m/s, m/s, rad/s"), or nil
--   live:retap(below)          -- the taps of the ports below(p) made again (their leaf was restarted)
--   live:line(line, t, output) -- a line of the run at time t (simulated seconds; nil: now, on the wall clock) to
--                                 Foxglove's /dca/events (or /dca/log: a process's stderr), as the recordings hold it
--   live:on_client(fn)         -- fn() once, when a Foxglove client watches (its first subscription: dca run
--                                 --monitor-wait)
--   live:stats()               -- { [path] = { taken, dropped, unpublished } }
--   live.robot                 -- a URDF world's { urdf, frames = { {parent, child}, ... }, topic, id } (else nil)
--   live:ended(t)              -- the run's outcome at t (simulated s): Foxglove's Time stops there
--   live:close()
local core = require "dca.core"
local async = require "dca.async"
local clients = require "dca.clients"
local taps = require "dca.supervisor.taps"

local M = {}

local ipairs, tostring, type, sformat, concat = ipairs, tostring, type, string.format, table.concat
local ROBOT_DESCRIPTION = "/robot_description"  -- (host/codec/frames.h, kDescriptionTopic)

local Live = {}
Live.__index = Live

--- The topic of the output at `path` (host/tap.h tap::topic_of).
function M.topic_of(path) return "/" .. path:gsub("%.", "/") end

-- The fields of a port's topic (as bindings/wrap_taps.cpp makes them): "value", "value[0]".., none (vectorx).
local function fields_of(p)
  if p.type == "scalar" then return { "value" } end
  local f = {}
  if p.type == "vector" then for i = 0, (p.size or 0) - 1 do f[#f + 1] = sformat("value[%d]", i) end end
  return f
end

-- Makes the topics of `list` (value ports have none: not numbers).
function Live:_topics(list)
  local have = {}
  for _, t in ipairs(self.srv:topics()) do have[t.name] = true end
  for _, p in ipairs(list) do
    local topic = M.topic_of(p.path)
    if p.type ~= "value" and not have[topic] then
      self.by_topic[topic] = p
      self.srv:topic(topic, fields_of(p), p.units)  -- (units: the schema's, as a recording's)
    end
  end
end

--- Starts the tap point, registers it at the root's daemon, makes the topics and serves Foxglove. (see the header)
function M.start(ctx, sup, srv, cb)
  local spec = ctx.spec
  local daemon = ctx.hosts[spec.host]
  local ip = tostring(daemon):match("^(%d+%.%d+%.%d+%.%d+):%d+$") or "127.0.0.1"
  local name = sformat("taps:%s@%d", spec.path, core.pid())
  -- a sample's time: its tick in simulated time; in a wall-clock run its arrival, on the Unix epoch
  local tp, err = core.tap_point{ name = name, host = spec.host, key_file = ctx.key, tcp = ip .. ":0", server = srv,
                                  stamp = ctx.o.sim and "writer" or "arrival" }
  if not tp then cb(nil, err) return end
  local self = setmetatable({ tp = tp, name = name, sup = sup, srv = srv, ctx = ctx, by_topic = {}, tapped = {},
                              stamp = ctx.o.sim and "writer" or "arrival" }, Live)
  self.config_set = function(values, k)
    sup:handle({ type = "config_set", key = values }, function(r) k(async.outcome(r)) end)
  end
  self.link = function(p, k)
    taps.connect(sup, { p }, name, { queue = 256, send = function(leaf, msg, timeout, k2) self:_send(leaf, msg, timeout, k2) end }, k)
  end
  self:_topics(taps.outputs(spec, sup.rt.types and sup.rt.types() or core.types()))
  self:_serve(daemon, ctx.key, "dca " .. spec.path, function(ok, err)
    if not ok then cb(nil, err) return end
    self:_world_topics(function(wok, werr)
      if not wok or ctx.o.monitor_taps == "picked" then cb(wok, werr) return end
      self:tap_all(function() cb(true) end)
    end)
  end)
  return self
end

-- Serves Foxglove on the server and registers the tap point at `daemon` (whose configuration repository Foxglove's
-- parameters read). k(true) | k(nil, err)
function Live:_serve(daemon, key, title, k)
  local sim = self.stamp == "writer"
  self.fox = core.foxglove(self.srv, { name = title, subscribe = function(topic) self:tap_topic(topic) end,
                            get_parameters = function(names, reply) self:_get_parameters(names, reply) end,
                            set_parameters = function(params, reply) self:_set_parameters(params, reply) end,
                            time = sim, watch = function() self:_client() end })
  self:_graph()
  self:_streams()
  if self.ctx.sim then self:_follow_time() end
  require("dca.clients.daemon").connect(daemon, clients.key_opts(key), function(d, derr)
    if not d then k(nil, sformat("live taps: the daemon at %s: %s", tostring(daemon), tostring(derr))) return end
    self.daemon = d
    self.config = require("dca.config").client(d)
    d:register(self.name, self.tp:endpoints(), clients.result(function(r, rerr)
      if not r then k(nil, "live taps: " .. tostring(rerr)) return end
      k(true)
    end))
  end)
end

-- The run's lines (/dca/events, /dca/log), as the recordings have them.
function Live:_streams()
  local wr = require "dca.launch.wall_record"
  self.streams = {}
  for _, c in ipairs({ { "/dca/events", "dca/events", wr.EVENTS_SCHEMA }, { "/dca/log", "dca/log", wr.LOG_SCHEMA } }) do
    self.streams[c[1]] = self.srv:stream_topic(c[1], c[2], c[3])
  end
end

function Live:line(line, t, output)
  if not self.streams then return end
  local topic, _, _, text = require("dca.launch.wall_record").line_message(line, output)
  self.srv:publish_message(self.streams[topic], t or -1, text)
  if t and self.fox then self.fox:time(t) end
end

-- The run ended at t (simulated s, the root's outcome): Foxglove's clock stops there; the shutdown after it (a
-- world that steps on while the tree stops) is no part of the run.
function Live:ended(t)
  if self.time_timer then self.time_timer:cancel() self.time_timer = nil end
  if self.fox and t then self.fox:end_time(t) end
end

-- A Foxglove client subscribed to its first channel: who waited for a viewer (--monitor-wait) goes on, once every
-- tap asked for so far is made (the channel it subscribed to then has its samples from the first step on).
function Live:_client()
  local pending = {}
  for _, state in pairs(self.tapped) do
    if type(state) == "table" then pending[#pending + 1] = state end
  end
  if #pending > 0 then
    local left = #pending
    for _, waiting in ipairs(pending) do
      waiting[#waiting + 1] = function() left = left - 1 if left == 0 then self:_client() end end
    end
    return
  end
  local waiting = self.client_waiters
  self.client_waiters, self.had_client = nil, true
  for _, fn in ipairs(waiting or {}) do fn() end
end

function Live:on_client(fn)
  if self.had_client then fn() return end
  self.client_waiters = self.client_waiters or {}
  self.client_waiters[#self.client_waiters + 1] = fn
end

-- In simulated time, Foxglove's clock is the world's: while a client is connected the world's time is asked for
-- every 0.1 s of wall time (samples and lines move it too).
function Live:_follow_time()
  local s, pending = self.ctx.sim, false
  self.time_timer = core.every(0.1, function()
    if pending or not (self.fox and self.fox:clients() > 0 and s.world:connected()) then return end
    pending = true
    s.world:request({ type = "status" }, 5, function(r)
      pending = false
      if r and tonumber(r.t) then self.fox:time(tonumber(r.t)) end
    end)
  end)
end

-- The connection graph Foxglove's Topic Graph panel draws: each output's topic published by its leaf, read by the
-- leaves its connections reach (every connection set, active or not); the world's signals published by "world".
function Live:_graph()
  local spec = self.ctx.spec
  if not (spec and self.fox) then return end
  local published, readers, order = {}, {}, {}
  for topic, p in pairs(self.by_topic) do
    published[#published + 1] = { topic, { p.leaf == "world" and "world" or p.leaf } }
  end
  require("dca.supervisor.spec").walk(spec, function(n)
    if n.kind ~= "group" then return end
    for _, w in ipairs(require("dca.supervisor.spec").wiring(n.spec) or {}) do
      local topic = M.topic_of(w.src .. "." .. w.out)
      if not readers[topic] then readers[topic] = {} order[#order + 1] = topic end
      local seen = false
      for _, id in ipairs(readers[topic]) do if id == w.dst then seen = true end end
      if not seen then table.insert(readers[topic], w.dst) end
    end
  end)
  local subscribed = {}
  for _, topic in ipairs(order) do subscribed[#subscribed + 1] = { topic, readers[topic] } end
  table.sort(published, function(a, b) return a[1] < b[1] end)
  self.fox:graph(published, subscribed)
end

-- Foxglove's getParameters: the keys `names` (none: every key) and their values, as the repository of the root's
-- host holds them; a name that is no key is left out. reply({ {name =, value =}... }) | reply(nil, err)
function Live:_get_parameters(names, reply)
  if not self.config then reply(nil, "the configuration repository is not reached yet") return end
  self.config:list("", function(entries, err)
    if not entries then reply(nil, tostring(err)) return end
    local want
    for _, n in ipairs(names) do want = want or {} want[n] = true end
    local out = {}
    for _, e in ipairs(entries) do
      if not want or want[e.key] then out[#out + 1] = { name = e.key, value = e.value } end
    end
    reply(out)
  end)
end

-- Foxglove's setParameters: one transaction written as the monitor's config_set (the root's repository, whose
-- watch tells the live leaves), answered with the keys' values after it, or the repository's refusal.
function Live:_set_parameters(params, reply)
  local values, names = {}, {}
  for _, p in ipairs(params) do
    values[p.name] = p.value
    names[#names + 1] = p.name
  end
  self.config_set(values, function(ok, err)
    if not ok then reply(nil, err) return end
    self:_get_parameters(names, reply)
  end)
end

-- (the tap point is on the root's host, as `--daemon`, the daemon of the root's host, says)
function M.attach(o, srv, request, cb)
  local ip = tostring(o.daemon):match("^(%d+%.%d+%.%d+%.%d+):%d+$") or "127.0.0.1"
  local name = sformat("taps:%s@%d", tostring(o.root), core.pid())
  local self = setmetatable({ name = name, srv = srv, ctx = { say = function() end }, by_topic = {}, tapped = {} }, Live)
  self.config_set = function(values, k)
    request({ type = "config_set", key = values }, function(r) k(async.outcome(r)) end)
  end
  self.link = function(p, k)
    request({ type = "tap", path = p.path, to = name }, function(r)
      local ok, why = async.outcome(r)
      if ok then k(true) else k(nil, why) end
    end)
  end
  request({ type = "ports" }, function(r)
    local ok, why = async.outcome(r)
    if not ok then cb(nil, "live taps: the root's ports: " .. why) return end
    local tp, err = core.tap_point{ name = name, host = tostring(r.host), key_file = o.key, tcp = ip .. ":0",
                                    server = srv, stamp = r.sim and "writer" or "arrival" }
    if not tp then cb(nil, err) return end
    self.tp, self.stamp = tp, r.sim and "writer" or "arrival"
    self:_topics(r.ports or {})
    self:_serve(o.daemon, o.key, "dca " .. tostring(o.root), cb)
  end)
  return self
end

-- With --sim: the world's signals ("world.arm.q": its outputs, as its `ports` lists them) are topics too; a
-- URDF world's link frames are foxglove.FrameTransforms, beside its URDF on /robot_description (_robot).
function Live:_world_topics(cb)
  local s = self.ctx.sim
  if not (s and s.world:connected()) then cb(true) return end
  s.world:request({ type = "ports" }, 10, function(r)
    local list = {}
    for _, o in ipairs(r and r.outputs or {}) do
      list[#list + 1] = { path = "world." .. o.name, leaf = "world", port = o.name, type = o.type, size = o.size,
                          units = o.units or "" }
    end
    self:_topics(list)
    self:_graph()  -- (again, with the world's signals)
    self:_robot(s.world, cb)
  end)
end

-- The robot a URDF world describes (`robot_description`: the door world has none): self.robot = { urdf, frames,
-- topic, id }, its frames topic marked as link frames and /robot_description made. cb(true) after.
function Live:_robot(world, cb)
  world:request({ type = "robot_description" }, 10, function(r)
    if not (r and type(r.frames) == "table" and #r.frames > 0 and type(r.urdf) == "string") then cb(true) return end
    local topic = M.topic_of("world." .. tostring(r.port))
    for _, t in ipairs(self.srv:topics()) do
      if t.name == topic then
        self.srv:robot(t.id, r.frames, r.urdf)
        self.robot = { urdf = r.urdf, frames = r.frames, topic = topic, id = t.id }
      end
    end
    cb(true)
  end)
end

-- The connection requests of a tap: to the world on its own channel, to a leaf through the tree.
function Live:_send(leaf, msg, timeout, k)
  if leaf ~= "world" then self.sup:to_leaf(leaf, msg, timeout, k) return end
  local s = self.ctx.sim
  if not (s and s.world:connected()) then k(nil, "the world is not connected") return end
  s.world:request(msg, timeout, function(r, err) k(r or { type = "error", reason = err }) end)
end

function Live:tap_topic(topic, cb, quiet)
  cb = cb or function(ok, err) if not ok then io.stderr:write("dca run: live tap ", tostring(topic), ": ", tostring(err), "\n") end end
  if self.streams and self.streams[topic] then cb(true) return end  -- the run's lines: published, never tapped
  if topic == ROBOT_DESCRIPTION and self.robot then cb(true) return end  -- the URDF: one message, served by the hub
  local p = self.by_topic[topic]
  if not p then cb(nil, "no port has the topic " .. tostring(topic)) return end
  local state = self.tapped[topic]
  if state == true then cb(true) return end
  if state then state[#state + 1] = cb return end  -- being made
  local waiting = { cb }
  self.tapped[topic] = waiting
  local added, aerr = self.tp:add(p.path, p.type, p.size, p.units, 256, p.message)
  local function finish(ok, err)
    self.tapped[topic] = ok and true or nil
    if ok and not quiet then self.ctx.say(sformat("live: tapped %s (%s)", p.path, topic)) end
    for _, w in ipairs(waiting) do w(ok, err) end
  end
  if not added then finish(nil, aerr) return end
  self.link(p, finish)
end

--- Every port's and world signal's tap (--monitor-taps all, the default), before time starts, so the server's hub
--- keeps each from t = 0 (host/web/sample_history.h). Not the link frames (the 3D view's, at the page's rate) nor
--- message ports (counted, never plotted). A tap that fails is said, the others go on. k() once all are made.
function Live:tap_all(k)
  local list = {}
  for topic, p in pairs(self.by_topic) do
    if p.type ~= "message" and not (self.robot and self.robot.topic == topic) then list[#list + 1] = topic end
  end
  table.sort(list)
  local left, made = #list + 1, 0
  local function one()
    left = left - 1
    if left > 0 then return end
    self.ctx.say(sformat("live: tapped %d of %d ports and world signals from the start (--monitor-taps)", made, #list))
    k()
  end
  for _, topic in ipairs(list) do self:tap_topic(topic, function(ok, err)
    if ok then made = made + 1 else self.ctx.say(sformat("live: no tap of %s: %s", topic, tostring(err))) end
    one()
  end, true) end
  one()
end

--- The units of topic `name`'s port, as its manifest writes them ("m/s, m/s, rad/s"), or nil.
function Live:units(name)
  local p = self.by_topic[name]
  return p and p.units ~= "" and p.units or nil
end

--- The tap of the topic with id `id` in the server's live samples (the monitor's page subscribes by id).
function Live:tap_id(id, cb)
  for _, t in ipairs(self.srv:topics()) do
    if t.id == id then
      if self.by_topic[t.name] then self:tap_topic(t.name, cb) elseif cb then cb(true) end
      return
    end
  end
  if cb then cb(nil, "no topic " .. tostring(id)) end
end

--- The taps of the ports `below(p)` says were restarted, made again on their new processes.
function Live:retap(below)
  for topic, state in pairs(self.tapped) do
    local p = self.by_topic[topic]
    if state == true and below(p) then
      self.tapped[topic] = nil
      self:tap_topic(topic)
    end
  end
end

function Live:stats() return self.tp and self.tp:stats() or {} end

function Live:close()
  if self.time_timer then self.time_timer:cancel() self.time_timer = nil end
  if self.daemon then self.daemon:close() self.daemon, self.config = nil, nil end
  if self.tp then self.tp:close() end
end

-- The names of the topics, for messages.
function Live:topics()
  local out = {}
  for t in pairs(self.by_topic) do out[#out + 1] = t end
  table.sort(out)
  return concat(out, ", ")
end

return M
