-- dca.clients.config: the client of the configuration repository (the paper's DBManager) over a daemon's
-- control channel; dca.config gives the same functions (connect, client, over_channel, sync), see there.
--
--   config.connect(addr, opts, cb)   -- cb(client) | cb(nil, err): its own channel to the daemon
--   config.client(d)                 -- over an open dca.clients.daemon `d` (its events handler is taken over
--                                    -- to deliver config_changed events; other events still reach the previous)
--   config.over_channel(ch, timeout) -- over a raw channel whose events are passed to client:event(msg)
--   config.sync(addr, opts)          -- the blocking form: methods return results (running the loop)
-- Requests wait dca.clients.TIMEOUT seconds unless opts.request_timeout says otherwise.
local core, clients = require "dca.core", require "dca.clients"
local literal = require "dca.literal"

local setmetatable, type, ipairs, pairs, tostring = setmetatable, type, ipairs, pairs, tostring
local sformat = string.format

local M = {}

local Client = {}
Client.__index = Client

local function ignore() end

local function under(key, prefix)
  return prefix == "" or key == prefix or key:sub(1, #prefix + 1) == prefix .. "."
end

local function trim(prefix)
  prefix = prefix or ""
  return (prefix:gsub("%.+$", ""))
end

local function new(request, timeout)
  return setmetatable({ request_fn = request, timeout = timeout or clients.TIMEOUT, watchers = {} }, Client)
end

-- Routes a config_changed event to the matching watchers. Returns true when it was one.
function Client:_event(msg)
  if msg.type ~= "config_changed" then return false end
  for _, w in ipairs(self.watchers) do
    if w.prefix == msg.prefix or (msg.prefix == nil and under(msg.key, w.prefix)) then
      w.fn({ key = msg.key, value = msg.value, stamp = msg.stamp, origin = msg.origin })
    end
  end
  return true
end

--- Connects to the daemon at `addr` (opts: those of core.connect, such as key_file, plus request_timeout in
--- seconds, default 5). cb(client) or cb(nil, err).
function M.connect(addr, opts, cb)
  opts = opts or {}
  core.connect(addr, opts, function(ch, err)
    if not ch then return cb(nil, sformat("cannot reach the daemon at %s: %s", tostring(addr), tostring(err))) end
    local self = new(function(msg, timeout, k) ch:request(msg, timeout, k) end, opts.request_timeout)
    self.channel = ch
    self.address = addr
    ch:on_message(function(msg) self:_event(msg) end)
    ch:on_close(function(reason)
      self.closed = reason
      if self.close_fn then self.close_fn(reason) end
    end)
    cb(self)
  end)
end

--- A config client over an open dca.clients.daemon `d` (its on_event handler forwards other events as before).
function M.client(d)
  local self = new(function(msg, timeout, k) d:request(msg, timeout, k) end, d.timeout)
  local previous = d.event_fn
  d:on_event(function(msg)
    if not self:_event(msg) and previous then previous(msg) end
  end)
  self.daemon = d
  return self
end

--- A config client over a raw dca.core channel `ch` to a daemon (as the supervisor's runtime holds them). Watch
--- events arrive on that channel's on_message handler: pass them to client:event(msg) (true when it was one).
function M.over_channel(ch, timeout)
  local self = new(function(msg, t, k) ch:request(msg, t, k) end, timeout)
  self.channel = ch
  return self
end

--- Delivers a config_changed event received elsewhere; false for other messages.
function Client:event(msg) return self:_event(msg) end

function Client:_request(msg, cb)
  self.request_fn(msg, self.timeout, cb or ignore)
end

--- cb(value, err, entry): the value of `key` (entry = { key, value, stamp = { ms, n, origin }, origin }).
function Client:get(key, cb)
  self:_request({ type = "config_get", key = key }, function(r, err)
    if not r then return cb(nil, err) end
    cb(r.value, nil, r)
  end)
end

--- Writes every key of `values` as one transaction; cb(reply, err) after the daemon committed it
--- (reply = { seq, stamp, origin, keys }).
--- Values are literals (dca.literal.check: finite numbers, strings, booleans, tables of them not too deep);
--- anything else is refused here, cb(nil, reason), and nothing is sent.
function Client:set(values, cb)
  if type(values) ~= "table" then (cb or ignore)(nil, "config set: values must be a table of key = value") return end
  for k, v in pairs(values) do
    local ok, why = literal.check(v)
    if not ok then (cb or ignore)(nil, sformat("config set %s: %s", tostring(k), why)) return end
  end
  self:_request({ type = "config_set", values = values }, cb)
end

--- cb(entries, err): the keys equal to `prefix` or below it ("" or nil: all), sorted.
function Client:list(prefix, cb)
  self:_request({ type = "config_list", prefix = prefix or "" }, function(r, err)
    if not r then return cb(nil, err) end
    cb(r.entries or {}, nil)
  end)
end

--- cb(log, err): the last n transactions and conflicts (newest first), the replica id and its version.
function Client:log(n, cb)
  self:_request({ type = "config_log", n = n or 20 }, cb)
end

--- cb(status, err): the replica and its peers.
function Client:status(cb)
  self:_request({ type = "config_status" }, cb)
end

--- Calls fn(ev) for every change below `prefix` (local or replicated); cb(reply, err) once the watch is set.
--- `owner` (optional) tags the watch: unwatch(prefix) ends the untagged ones (a console's), unwatch(prefix, cb,
--- owner) that owner's (a supervisor's, dca.supervisor.live), so neither ends the other's.
function Client:watch(prefix, fn, cb, owner)
  prefix = trim(prefix)
  self:_request({ type = "config_watch", prefix = prefix }, function(r, err)
    if r then self.watchers[#self.watchers + 1] = { prefix = prefix, fn = fn, owner = owner } end
    if cb then cb(r, err) end
  end)
end

--- Stops the watches of `prefix` (of `owner`, see watch); the daemon stops sending its changes once no watch of
--- the prefix is left on this client.
function Client:unwatch(prefix, cb, owner)
  prefix = trim(prefix)
  local left = false
  for i = #self.watchers, 1, -1 do
    local w = self.watchers[i]
    if w.prefix == prefix and w.owner == owner then table.remove(self.watchers, i)
    elseif w.prefix == prefix then left = true end
  end
  -- (another's watch of it stays: asked again, which the daemon keeps as one, so cb still comes from the loop)
  self:_request({ type = left and "config_watch" or "config_unwatch", prefix = prefix }, cb)
end

function Client:on_close(fn) self.close_fn = fn end
function Client:close(reason)
  if self.channel then self.channel:close(reason) end
end

-- ------------------------------------------------------------------------------------------- blocking forms

local Sync = {}
Sync.__index = Sync

-- Runs the loop until cb is called; returns what it was called with.
local function block(self, start)
  local done, a, b, c = false, nil, nil, nil
  start(function(x, y, z) done, a, b, c = true, x, y, z end)
  if not self.loop:run_until(function() return done end, self.client.timeout + 1) then
    return nil, "no reply from the daemon within " .. tostring(self.client.timeout) .. " s"
  end
  return a, b, c
end

function Sync:get(key) return block(self, function(k) self.client:get(key, k) end) end
function Sync:set(values) return block(self, function(k) self.client:set(values, k) end) end
function Sync:list(prefix) return block(self, function(k) self.client:list(prefix, k) end) end
function Sync:log(n) return block(self, function(k) self.client:log(n, k) end) end
function Sync:status() return block(self, function(k) self.client:status(k) end) end
function Sync:watch(prefix, fn) return block(self, function(k) self.client:watch(prefix, fn, k) end) end
function Sync:unwatch(prefix) return block(self, function(k) self.client:unwatch(prefix, k) end) end
--- Runs the loop until pred() is true or `seconds` pass (watch events are delivered meanwhile).
function Sync:wait(pred, seconds) return self.loop:run_until(pred, seconds) end
function Sync:close(reason) self.client:close(reason) end

--- A blocking client: c = config.sync(addr, opts); c:get(key) --> value, err, entry. nil, err when it cannot
--- connect. Its methods run the loop until the reply arrives (events for watchers are delivered while they do).
function M.sync(addr, opts)
  opts = opts or {}
  local loop = core.loop()
  local done, client, err = false, nil, nil
  M.connect(addr, opts, function(c, e) done, client, err = true, c, e end)
  if not loop:run_until(function() return done end, (opts.timeout or clients.TIMEOUT) + 1) then
    return nil, "cannot reach the daemon at " .. tostring(addr) .. ": no answer"
  end
  if not client then return nil, err end
  return setmetatable({ client = client, loop = loop }, Sync)
end

return M
