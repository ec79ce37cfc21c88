-- dca.clients: what every protocol client (dca.clients.daemon, .node, .world; dca.config) shares: one way to
-- wrap a control channel, one timeout policy and one lookup helper.
--
--   local clients = require "dca.clients"
--   local c = clients.wrap(ch, Class, opts)      -- Class's methods over channel `ch`; c:request(msg, t, cb)
--   clients.connect(addr, opts, Class, cb)       -- core.connect + wrap: cb(client) | cb(nil, err)
--   clients.lookup(daemon, name, wait, cb)       -- cb(endpoints) | cb(nil, err): `name` registered within `wait` s
--   clients.open(daemon, name, wait, opts, Class, cb) -- lookup, then connect to its `control` endpoint
--
-- Timeout policy: a request waits clients.TIMEOUT seconds (opts.request_timeout overrides it per client); a
-- request that itself waits `w` seconds on the far side (a lookup's wait_ms, a pull) waits w + TIMEOUT.
-- Callbacks run exactly once, from the loop: cb(reply) or cb(nil, err), an error reply turned into its reason
-- when the caller asks for it (clients.result).
local core = require "dca.core"
local async = require "dca.async"

local setmetatable, tostring, sformat, floor = setmetatable, tostring, string.format, math.floor

local M = {}

--- Seconds a request waits for its reply (the one default of every client).
M.TIMEOUT = 5

--- Connection options of core.connect/core.listen for a key file path (nil: dca.core's default key).
function M.key_opts(key_file)
  return { key_file = key_file }
end

local function ignore() end

--- The methods every client has: request, on_close, close, is_open.
local Base = {}

function Base:request(msg, timeout, cb)
  self.channel:request(msg, timeout or self.timeout, cb or ignore)
end

--- fn(reason) once the channel closes (from the loop at once when it already has).
function Base:on_close(fn)
  self.close_fn = fn
  if self.closed then core.after(0, function() fn(self.closed) end) end
end

function Base:close(reason) self.channel:close(reason) end
function Base:is_open() return self.channel:is_open() end

--- Makes `Class` a client class: its instances find Base's methods after their own.
function M.class(Class)
  Class.__index = Class
  return setmetatable(Class, { __index = Base })
end

--- Wraps an open channel `ch`: an instance of `Class` whose events go to Class._event(self, msg, id) (when it
--- has one) and whose channel's close is remembered and passed to on_close's handler.
function M.wrap(ch, Class, opts)
  opts = opts or {}
  local self = setmetatable({ channel = ch, timeout = opts.request_timeout or M.TIMEOUT }, Class)
  ch:on_message(function(msg, id)
    if self._event then self:_event(msg, id) end
  end)
  ch:on_close(function(reason)
    self.closed = reason or "closed"
    if self.close_fn then self.close_fn(reason) end
  end)
  return self
end

--- Connects to `addr` (opts: those of core.connect plus request_timeout) and wraps the channel in `Class`.
--- cb(client) | cb(nil, err)
function M.connect(addr, opts, Class, cb)
  core.connect(addr, opts or {}, function(ch, err)
    if not ch then cb(nil, err) return end
    cb(M.wrap(ch, Class, opts))
  end)
end

--- Splits a reply: cb(reply) for a success, cb(nil, reason) for an error reply or no reply.
function M.result(cb)
  return function(r, err)
    cb(async.outcome(r, err))
  end
end

--- The endpoints of the process registered as `name`, asked of `daemon` (a dca.clients.daemon client, which
--- asks its peers too), waiting up to `wait` seconds for it to register. cb(endpoints) | cb(nil, err)
function M.lookup(daemon, name, wait, cb)
  local wait_ms = floor((wait or 0) * 1000)
  daemon:request({ type = "lookup", name = name, wait_ms = wait_ms }, wait_ms / 1000 + daemon.timeout,
    M.result(function(r, err)
      if not r then cb(nil, err) return end
      cb(r.endpoints or r)
    end))
end

--- Looks `name` up (see lookup) and connects to its `control` endpoint: cb(client of Class) | cb(nil, err,
--- missing), missing = true when the lookup failed for any reason, a timeout included (err says which).
function M.open(daemon, name, wait, opts, Class, cb)
  M.lookup(daemon, name, wait, function(ep, err)
    if not ep then cb(nil, err, true) return end
    if not ep.control then cb(nil, name .. " registered no control endpoint") return end
    M.connect(ep.control, opts, Class, function(c, cerr)
      if not c then cb(nil, sformat("%s at %s: %s", name, ep.control, tostring(cerr))) return end
      cb(c)
    end)
  end)
end

--- A class with no events of its own (a plain request/reply client).
M.Plain = M.class({})

return M
