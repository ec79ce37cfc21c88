-- dca.config: the configuration repository (the paper's DBManager) from Lua, over a daemon's control channel.
--
--   local config = require "dca.config"
--   config.connect("127.0.0.1:4000", { key_file = path }, function(c, err)
--     c:set({ ["door.stop_distance"] = 0.45 }, function(reply, err) end)   -- one transaction, acked after commit
--     c:get("door.stop_distance", function(value, err, entry) end)         -- entry = { key, value, stamp, origin }
--     c:list("door", function(entries, err) end)                           -- { { key, value, stamp, origin }... }
--     c:log(20, function(log, err) end)                                    -- { txns = {...}, conflicts = {...} }
--     c:watch("door", function(ev) end, function(reply, err) end)          -- ev = { key, value, stamp, origin }
--   end)
--
-- Every callback runs exactly once from the loop: the result, or nil and the reason (the daemon's error, such
-- as "unknown key 'door.widht' (did you mean door.width?) on host h1", a timeout, or the channel's close).
-- config.client(daemon_client) uses an open dca.daemon_client instead (its event handler is taken over to
-- deliver config_changed events to the watchers; other events still reach the previous handler).
-- Blocking forms for scripts, the REPL and the CLI: config.sync(addr, opts) gives an object whose methods
-- return results directly (running the loop until the reply, bounded by the request timeout).
-- config.resolve_params(args, client, cb) resolves the `config("key")` parameters of a controller (see below).
local core = require "dca.core"

local setmetatable, type, ipairs, tostring = setmetatable, type, ipairs, tostring
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
  return setmetatable({ request_fn = request, timeout = timeout or 5, watchers = {} }, Client)
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

--- A config client over an open dca.daemon_client `d` (its on_event handler forwards other events as before).
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
function Client:set(values, cb)
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
function Client:watch(prefix, fn, cb)
  prefix = trim(prefix)
  self:_request({ type = "config_watch", prefix = prefix }, function(r, err)
    if r then self.watchers[#self.watchers + 1] = { prefix = prefix, fn = fn } end
    if cb then cb(r, err) end
  end)
end

--- Stops the watches of `prefix`.
function Client:unwatch(prefix, cb)
  prefix = trim(prefix)
  for i = #self.watchers, 1, -1 do
    if self.watchers[i].prefix == prefix then table.remove(self.watchers, i) end
  end
  self:_request({ type = "config_unwatch", prefix = prefix }, cb)
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
  if not loop:run_until(function() return done end, (opts.timeout or 5) + 1) then
    return nil, "cannot reach the daemon at " .. tostring(addr) .. ": no answer"
  end
  if not client then return nil, err end
  return setmetatable({ client = client, loop = loop }, Sync)
end

-- ------------------------------------------------------------------------------- controller parameters

local function fits(value, want)
  if want == "integer" then return math.type(value) == "integer" end
  return type(value) == want
end

local function render(v)
  if type(v) == "string" then return sformat("%q", v) end
  return tostring(v)
end

--- Whether `v` is a parameter naming a configuration key: the table { config = "door.stop_distance" } (what a
--- .dca file's `config("door.stop_distance")` becomes), or the string "config:door.stop_distance".
function M.param_key(v)
  if type(v) == "table" and type(v.config) == "string" then return v.config end
  if type(v) == "string" then return v:match("^config:(.+)$") end
  return nil
end

--- Resolves the configuration parameters of one controller: a copy of `args` where each parameter naming a key
--- (M.param_key) is replaced by the key's value, read through `client` (a Client). `what` names the controller
--- in errors: { process = "main.door.det", host = "h2", params = <the type's manifest params> } (all optional;
--- params[i] names args[i], a string or a manifest entry { name, type }). cb(resolved) or cb(nil, err), where
--- err names the process, the parameter and the key. `expect` (optional) maps an index to the Lua type the value
--- must have ("number", "string", "boolean", "table"); without it a manifest entry's type "number"/"integer"
--- expects a number (an integer for "integer") and "string" a string.
--- For a leaf of dca.model: resolve_params(leaf.params, client, cb, { process = leaf.path, host = leaf.host,
--- params = leaf.manifest and leaf.manifest.params }) -- leaf.params are the arguments after the host.
function M.resolve_params(args, client, cb, what, expect)
  what = what or {}
  local out, pending, failed = {}, 1, nil
  for i = 1, (args.n or #args) do out[i] = args[i] end
  out.n = args.n
  local function describe(i, key)
    local pname = what.params and what.params[i]
    pname = type(pname) == "table" and pname.name or pname
    return sformat("%sparameter %d%s (config key '%s')",
      what.process and ("process " .. what.process .. (what.host and (" on host " .. tostring(what.host)) or "") .. ": ") or "",
      i, pname and (" '" .. tostring(pname) .. "'") or "", key)
  end
  local function want(i)
    if expect and expect[i] then return expect[i] end
    local p = what.params and what.params[i]
    local t = type(p) == "table" and p.type
    if t == "number" or t == "integer" or t == "string" or t == "boolean" then return t end
    return nil
  end
  local function finish()
    pending = pending - 1
    if pending == 0 then
      if failed then cb(nil, failed) else cb(out) end
    end
  end
  for i = 1, (args.n or #args) do
    local key = M.param_key(args[i])
    if key then
      pending = pending + 1
      client:get(key, function(value, err)
        if err then
          failed = failed or (describe(i, key) .. ": " .. tostring(err))
        elseif want(i) and not fits(value, want(i)) then
          failed = failed or sformat("%s: the value %s is %s, not %s", describe(i, key), render(value),
            math.type(value) == "float" and "a float" or ("a " .. type(value)), want(i) == "integer" and "an integer"
            or ("a " .. want(i)))
        else
          out[i] = value
        end
        finish()
      end)
    end
  end
  finish()
end

return M
