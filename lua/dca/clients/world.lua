-- dca.clients.world: the client of the robot process registered as `world` (`dca sim --serve`, or a robot's
-- driver): started through a host's daemon, reached on its control channel, asked for status, read, hold, go
-- and exit (ARCHITECTURE.md, "Time" and "The robot: device ports").
--
--   local world = require "dca.clients.world"
--   local w = world.new{ daemon = ADDR, host = NAME, key = FILE, world = SPEC, seed = N,
--                        world_opts = { "KEY=VALUE", ... }, record = FILE, realtime = true, wait = S, log = FILE }
--   (log: the daemon's output file, when local: a world that ends while starting is shown with its own words)
--   w:start(function(ok, err) end)     -- spawn `dca sim --serve`, wait until `world` is registered, connect
--   w:request(msg, timeout, cb)        -- cb(reply) | cb(nil, err)
--   w:go(cb)  w:hold(cb)               -- time flows / stops after the current tick
--   w:stop(cb)                         -- `exit` to the world, then waits for its exit (SIGKILL after a grace)
--   w.on_lost = function(reason) end   -- the world exited by itself (every node on its clock stops)
--   w:watch_estop(fn, cb)              -- fn(event {latched, t, source}) at each press and release of the
--                                      -- emergency stop (docs/safety.md); cb(state now) | cb(nil, err)
--   o.world_opts: the world's own options (`--world-opt`, docs/worlds.md); o.realtime: simulated time paced to the wall clock;
--   o.tick_timeout: ms a node may take to answer an advance before it is dropped from the clock
--   o.spin: "auto" (default), "off" or µs: how long nodes poll for their next advance (docs/time.md "Spinning")
--   Another robot process (a driver: dca.launch.driver): o.argv its argv, o.what its name in messages, o.said
--   the prefix of its own lines in the log, o.class its client's class (default dca.clients.Plain)
local core = require "dca.core"
local clients = require "dca.clients"
local daemon_client = require "dca.clients.daemon"

local M = {}

local ipairs, tostring, sformat = ipairs, tostring, string.format

local W = {}
W.__index = W

--- The options a world takes besides where it runs (see the header): what a system's start passes through.
M.OPTIONS = { "world", "seed", "world_opts", "record", "record_outputs", "blackbox", "blackbox_storm", "realtime", "wait", "trace",
              "tick_timeout", "spin", "record_compression", "record_split", "record_profile" }

-- A robot world's spec with its URDF file made absolute ("mock:FILE?OPTIONS" keeps its prefix and options), and
-- a replay's recording (replay:FILE.mcap): the world process starts in its daemon's folder (docs/robots.md). Any
-- other world name as it is.
local function world_spec(w)
  local replayed = type(w) == "string" and w:match("^replay:(.+)$")
  if replayed then return "replay:" .. core.absolute(replayed) end
  if type(w) ~= "string" or not w:find("%.urdf") then return w end
  local prefix, rest = w:match("^(mock:)(.*)$")
  local file, options = (rest or w):match("^([^?]*)(.*)$")
  return (prefix or "") .. core.absolute(file) .. options
end

--- The argv of the world process for options `o` (see the header).
function M.argv(o)
  local argv = { "dca", "sim", "--serve", "--daemon", o.daemon, "--host", o.host, "--world", world_spec(o.world) }
  if o.key then argv[#argv + 1] = "--key" argv[#argv + 1] = o.key end
  if o.seed then argv[#argv + 1] = "--seed" argv[#argv + 1] = tostring(o.seed) end
  for _, kv in ipairs(o.world_opts or {}) do argv[#argv + 1] = "--world-opt" argv[#argv + 1] = tostring(kv) end
  if o.record then argv[#argv + 1] = "--record" argv[#argv + 1] = o.record end
  if o.record_outputs then argv[#argv + 1] = "--record-outputs" end
  if o.record_compression then argv[#argv + 1] = "--record-compression" argv[#argv + 1] = o.record_compression end
  if o.record_split then argv[#argv + 1] = "--record-split" argv[#argv + 1] = o.record_split end
  if o.record_profile then argv[#argv + 1] = "--record-profile" argv[#argv + 1] = o.record_profile end
  if o.blackbox then argv[#argv + 1] = "--blackbox" argv[#argv + 1] = o.blackbox end
  if o.blackbox_storm then argv[#argv + 1] = "--blackbox-storm" argv[#argv + 1] = o.blackbox_storm end
  if o.trace then argv[#argv + 1] = "--trace" argv[#argv + 1] = o.trace end
  if o.realtime then argv[#argv + 1] = "--realtime" end
  -- (ms: a node that does not answer an advance within it is dropped from the clock; default 10000)
  if o.tick_timeout then argv[#argv + 1] = "--tick-timeout" argv[#argv + 1] = tostring(o.tick_timeout) end
  if o.spin then argv[#argv + 1] = "--spin" argv[#argv + 1] = tostring(o.spin) end
  return argv
end

function M.new(o)
  return setmetatable({ o = o }, W)
end

-- The world's channel: its events (`estop`) go to the W that owns it.
local Events = clients.class({})
function Events:_event(msg)
  if msg.type == "estop" and self.owner and self.owner.on_estop then self.owner.on_estop(msg) end
end

-- The world's exit event: remembered, and told to whoever waits (a start not finished fails with it).
function W:_exit(msg, finish)
  self.exited = daemon_client.describe_exit(msg, self.o.host)
  local what = self.o.what or "the world"
  if not self.stopping and self.started and self.on_lost then
    self.on_lost(what .. " " .. self.exited .. self:_own_words(": the world stops$"))
  end
  local ws = self.exit_waiters or {}
  self.exit_waiters = nil
  for _, w in ipairs(ws) do w() end
  finish(nil, (self.o.what or "the world (dca sim --serve)") .. " " .. self.exited .. self:_own_words())
end

-- What the world said before it ended, when its daemon's log is at hand (o.log: a daemon `dca run` started
-- keeps the output of its children there): its "dca sim:" lines, e.g. the URDF's XML error with file:line;
-- with `pattern`, those of them that match it (why it stopped by itself).
function W:_own_words(pattern)
  local f = self.o.log and io.open(self.o.log, "r")
  if not f then return "" end
  local said = {}
  for line in f:lines() do
    if line:find(self.o.said or "dca sim: ", 1, true) == 1 and (not pattern or line:find(pattern)) then
      said[#said + 1] = "\n  " .. line
    end
  end
  f:close()
  return table.concat(said)
end

--- Spawns the world through the daemon at o.daemon and connects to it once it has registered.
--- cb(true) | cb(nil, err naming the host)
function W:start(cb)
  local o = self.o
  local done = false
  local function finish(ok, err)
    if done then return end
    done = true
    self.started = ok
    cb(ok, err)
  end
  daemon_client.connect(o.daemon, clients.key_opts(o.key), function(dc, err)
    if not dc then finish(nil, sformat("the daemon of host %s at %s: %s", o.host, o.daemon, tostring(err))) return end
    self.daemon = dc
    dc:spawn(o.argv or M.argv(o), { name = "world", timeout = 10, on_exit = function(msg) self:_exit(msg, finish) end },
      clients.result(function(r, serr)
        if not r then finish(nil, sformat("could not start the world on host %s: %s", o.host, tostring(serr))) return end
        self.child, self.pid = r.child, r.pid
        self:_connect(dc, finish)
      end))
  end)
end

-- Waits until the world has registered (o.wait seconds, default 60) and connects to it.
function W:_connect(dc, finish)
  local wait = self.o.wait or 60
  local class = self.o.class or Events
  clients.open(dc, "world", wait, clients.key_opts(self.o.key), class, function(c, err, missing)
    if not c then
      finish(nil, missing and sformat("the world did not register within %gs: %s", wait, tostring(err)) or
        ("the " .. tostring(err)))
      return
    end
    self.client = c
    c.owner = self
    finish(true)
  end)
end

--- Whether the world is connected.
function W:connected() return self.client ~= nil end

--- A request to the world. cb(reply | nil, err)
function W:request(msg, timeout, cb)
  if not self.client then cb(nil, "the world is not connected") return end
  self.client:request(msg, timeout or 10, clients.result(cb))
end

--- Each press and release of the emergency stop told: fn(event). cb(state now) | cb(nil, err)
function W:watch_estop(fn, cb)
  self.on_estop = fn
  self:request({ type = "estop_watch" }, 10, cb or function() end)
end

function W:go(cb) self:request({ type = "go" }, 10, cb or function() end) end
--- Time stops after the current tick. cb(reply {now} | nil, err)
function W:hold(cb) self:request({ type = "hold" }, 10, cb or function() end) end

--- Ends the world: `exit`, then SIGTERM and SIGKILL through its daemon if it lingers. cb() once it exited
--- (or after the last bound).
function W:stop(cb)
  cb = cb or function() end
  self.stopping = true
  if not self.child or self.exited or not self.daemon then cb() return end
  local called = false
  local function done() if not called then called = true cb() end end
  self.exit_waiters = self.exit_waiters or {}
  self.exit_waiters[#self.exit_waiters + 1] = done
  if self.client then self.client:request({ type = "exit" }, 5) end
  local grace = self.o.stop_grace or 5
  core.after(grace, function()
    if self.exited then return end
    self.daemon:kill(self.child, "TERM")
    core.after(grace, function()
      if self.exited then return end
      self.daemon:kill(self.child, "KILL")
      core.after(grace, done)
    end)
  end)
end

function W:close()
  if self.client then self.client:close() end
  if self.daemon then self.daemon:close() end
end

return M
