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

-- ------------------------------------------------------------------------------------------- values as text

--- A value as Lua-like text: strings quoted, whole floats with ".0", tables with sorted keys.
local function render(v, depth)
  depth = depth or 0
  local t = type(v)
  if t == "string" then return sformat("%q", v) end
  if t == "number" then
    if math.type(v) == "float" and v == math.floor(v) and v >= -1e15 and v <= 1e15 then return sformat("%.1f", v) end
    return tostring(v)
  end
  if t ~= "table" then return tostring(v) end
  if depth > 8 then return "{...}" end
  local parts, n = {}, #v
  for i = 1, n do parts[#parts + 1] = render(v[i], depth + 1) end
  local keys = {}
  for k in pairs(v) do
    if not (math.type(k) == "integer" and k >= 1 and k <= n) then keys[#keys + 1] = k end
  end
  table.sort(keys, function(a, b) return tostring(a) < tostring(b) end)
  for _, k in ipairs(keys) do
    local ks = type(k) == "string" and k:match("^[%a_][%w_]*$") and k or ("[" .. render(k, depth + 1) .. "]")
    parts[#parts + 1] = ks .. " = " .. render(v[k], depth + 1)
  end
  return "{ " .. table.concat(parts, ", ") .. " }"
end

local function stamp_text(s)
  if type(s) ~= "table" then return "?" end
  return sformat("%s.%d@%s", os.date("!%Y-%m-%dT%H:%M:%S", math.floor(s.ms / 1000)) ..
    sformat(".%03dZ", s.ms % 1000), s.n or 0, tostring(s.origin))
end

--- The text of a `config_log` reply: the replica, its transactions and its conflicts, newest first.
function M.format_log(log)
  local out = { sformat("replica %s (host %s, %s): %d transactions", log.replica, log.host, log.path,
    log.transactions), "transactions, newest first:" }
  for _, t in ipairs(log.txns or {}) do
    local ws = {}
    for _, w in ipairs(t.writes or {}) do ws[#ws + 1] = w.key .. " = " .. render(w.value) end
    out[#out + 1] = sformat("  %s #%d  %s  %s", t.origin, t.seq, stamp_text(t.stamp), table.concat(ws, ", "))
  end
  out[#out + 1] = "conflicts, newest first:" .. (#(log.conflicts or {}) == 0 and " none" or "")
  for _, x in ipairs(log.conflicts or {}) do
    out[#out + 1] = sformat("  %s: %s (%s) won over %s (%s)", x.key, render(x.winner.value),
      stamp_text(x.winner.stamp), render(x.loser.value), stamp_text(x.loser.stamp))
  end
  return table.concat(out, "\n")
end

M.render = render

-- ------------------------------------------------------------------------------- controller parameters

local function fits(value, want)
  if want == "integer" then return math.type(value) == "integer" end
  return type(value) == want
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
--- For a leaf of dca.lang.model: resolve_params(leaf.params, client, cb, { process = leaf.path, host = leaf.host,
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

--- Whether any of a controller's arguments names a configuration key (M.param_key).
function M.has_params(args)
  for _, a in ipairs(args or {}) do
    if M.param_key(a) then return true end
  end
  return false
end

--- resolve_params for a controller's arguments (what a node's command line carries): besides, a value read for
--- a key must be a number, a string or a boolean. cb(resolved) | cb(nil, err naming the parameter and the key).
function M.resolve_controller_params(args, client, cb, what)
  M.resolve_params(args, client, function(out, err)
    if not out then return cb(nil, err) end
    for i = 1, (args.n or #args) do
      local key, t = M.param_key(args[i]), type(out[i])
      if key and t ~= "number" and t ~= "string" and t ~= "boolean" then
        return cb(nil, sformat("%sparameter %d (config key '%s'): the value is a %s; a controller parameter is a "
          .. "number, a string or a boolean", what and what.process and ("process " .. what.process .. ": ") or "",
          i, key, t))
      end
    end
    cb(out)
  end, what)
end

-- ------------------------------------------------------------------------------------ defaults files and seeding

--- The value of a Lua literal (0.45, true, "text", {1, 2}), or nil when text is not one.
local function literal(text)
  local chunk = load("return " .. text, "=value", "t", {})
  if not chunk then return nil end
  local ok, v = pcall(chunk)
  if ok and v ~= nil and type(v) ~= "function" then return v end
  return nil
end

--- Parses "KEY=VALUE" (`dca config set`, `dca run --set`, the console's `set`): the key, and the value as a Lua
--- literal (else the text itself). --> key, value | nil, err when there is no '='.
function M.parse_assignment(text)
  local key, raw = text:match("^([^=]+)=(.*)$")
  if not key then return nil, "expected KEY=VALUE, got '" .. text .. "'" end
  local v = literal(raw)
  if v == nil then return key, raw end
  return key, v
end

--- Reads a file of configuration defaults: one `key = value` per line, the value a Lua literal (0.45, 75,
--- true, "right", {1, 2}); `#` or `--` starts a comment. --> { { key =, value =, line = }, ... } (in file
--- order) | nil, "FILE:LINE:COL: what is wrong".
function M.read_file(path)
  local f, ferr = io.open(path, "r")
  if not f then return nil, sformat("cannot read configuration file %s", tostring(ferr)) end
  local out, seen, n = {}, {}, 0
  for line in f:lines() do
    n = n + 1
    local text = (line:match("^%s*#") or line:match("^%s*%-%-")) and "" or line
    if text:match("%S") then
      local lead, key, eq, raw = text:match("^(%s*)([%w_%.%-]+)(%s*=%s*)(.-)%s*$")
      local function fail(col, msg)
        f:close()
        return nil, sformat("%s:%d:%d: %s", path, n, col, msg)
      end
      if not key then
        return fail(#text:match("^%s*") + 1, "expected `key = value`, got '" .. text:gsub("^%s+", "") .. "'")
      end
      local col = #lead + #key + #eq + 1
      if key:sub(1, 1) == "." or key:sub(-1) == "." or key:find("..", 1, true) then
        return fail(#lead + 1, "'" .. key .. "' is not a dotted key (like door.stop_distance)")
      end
      if raw == "" then return fail(col, "no value for " .. key) end
      -- the value, else the value before a trailing `# comment` (a `#` inside a string is kept)
      local v
      for _, candidate in ipairs({ raw, (raw:gsub("%s+#[^\"']*$", "")), (raw:gsub("%s*#.*$", "")) }) do
        v = literal(candidate)
        if v ~= nil then raw = candidate break end
      end
      if v == nil then
        return fail(col, "the value of " .. key .. " is not a Lua literal (a number, true/false, a \"string\" or a {table}): " .. raw)
      end
      if seen[key] then return fail(#lead + 1, sformat("%s is set twice (first at line %d)", key, seen[key])) end
      seen[key] = n
      out[#out + 1] = { key = key, value = v, line = n }
    end
  end
  f:close()
  return out
end

local function same(a, b)
  if type(a) ~= type(b) then return false end
  if type(a) ~= "table" then return a == b end  -- 6.0 may come back as 6 (msgpack keeps the smaller form)
  for k, v in pairs(a) do if not same(v, b[k]) then return false end end
  for k in pairs(b) do if a[k] == nil then return false end end
  return true
end
M.same = same

--- Seeds a repository through the blocking client `c` (M.sync): each entry of `defaults` ({ { key, value } })
--- whose key the repository lacks, and every key of `overrides` ({ key = value }) whatever it holds, written
--- as one transaction. --> { seeded = n, kept = n, set = n, values = { key = value written } } | nil, err
function M.seed(c, defaults, overrides)
  local have, err = c:list("")
  if not have then return nil, err end
  local present = {}
  for _, e in ipairs(have) do present[e.key] = true end
  local values, r = {}, { seeded = 0, kept = 0, set = 0, values = {} }
  for _, d in ipairs(defaults or {}) do
    if present[d.key] then r.kept = r.kept + 1
    elseif values[d.key] == nil then values[d.key] = d.value r.seeded = r.seeded + 1 end
  end
  for k, v in pairs(overrides or {}) do
    if values[k] ~= nil then r.seeded = r.seeded - 1 elseif present[k] then r.kept = r.kept - 1 end
    values[k] = v
    r.set = r.set + 1
  end
  if next(values) == nil then return r end
  local ok, serr = c:set(values)
  if not ok then return nil, serr end
  r.values = values
  return r
end

--- Waits until the replica behind the blocking client `c` holds every key of `values` with that value
--- (replication from the daemon that took the write), polling every 20 ms for at most `seconds`.
--- --> true | nil, err naming the keys still missing
function M.wait_for(c, values, seconds)
  local deadline = core.now() + (seconds or 10)
  local missing
  repeat
    missing = {}
    local entries = c:list("")
    local got = {}
    for _, e in ipairs(entries or {}) do got[e.key] = e.value end
    for k, v in pairs(values) do
      if not same(got[k], v) then missing[#missing + 1] = k end
    end
    if #missing == 0 then return true end
    c:wait(function() return false end, 0.02)
  until core.now() > deadline
  table.sort(missing)
  return nil, sformat("%d key%s not replicated within %gs: %s", #missing, #missing == 1 and "" or "s",
    seconds or 10, table.concat(missing, ", ", 1, math.min(#missing, 5)))
end

--- The defaults file of a system: FILE.config beside FILE.dca (door_open.dca -> door_open.config), when it
--- exists. --> path | nil
function M.defaults_file(dca_file)
  if not dca_file then return nil end
  local path = dca_file:gsub("%.dca$", "") .. ".config"
  local f = io.open(path, "r")
  if not f then return nil end
  f:close()
  return path
end

--- Seeds the repository of a run before its tree starts: the defaults file's keys the repository lacks and
--- the `set` keys, written as one transaction on the daemon of `origin` (a host name of `hosts`, a map
--- name -> address), then waits until the replica of every other host holds them (a controller's
--- config("key") is read from its own host's replica). opts = { key_file =, file = defaults file | nil,
--- set = { key = value } | nil, timeout = s (default 10) }. --> a line saying what was done | nil, err
function M.seed_run(hosts, origin, opts)
  local defaults = {}
  if opts.file then
    local d, err = M.read_file(opts.file)
    if not d then return nil, err end
    defaults = d
  end
  if #defaults == 0 and not (opts.set and next(opts.set)) then return nil end
  local copts = { key_file = opts.key_file, timeout = opts.timeout }
  local c, err = M.sync(hosts[origin], copts)
  if not c then return nil, sformat("configuration repository of host %s: %s", tostring(origin), tostring(err)) end
  local r, serr = M.seed(c, defaults, opts.set)
  c:close()
  if not r then return nil, sformat("configuration repository of host %s: %s", tostring(origin), tostring(serr)) end
  local names = {}
  for name in pairs(hosts) do if name ~= origin then names[#names + 1] = name end end
  table.sort(names)
  if next(r.values) then
    for _, name in ipairs(names) do
      local o, oerr = M.sync(hosts[name], copts)
      if not o then return nil, sformat("configuration repository of host %s: %s", name, tostring(oerr)) end
      local ok, werr = M.wait_for(o, r.values, opts.timeout or 10)
      o:close()
      if not ok then return nil, sformat("configuration repository of host %s: %s", name, werr) end
    end
  end
  local parts = {}
  if opts.file then
    parts[#parts + 1] = sformat("%s: %d key%s seeded, %d already set", opts.file, r.seeded, r.seeded == 1 and "" or "s",
      r.kept)
  end
  if r.set > 0 then parts[#parts + 1] = sformat("%d key%s set", r.set, r.set == 1 and "" or "s") end
  return sformat("config: %s (on host %s%s)", table.concat(parts, "; "), tostring(origin),
    #names > 0 and (", replicated to " .. table.concat(names, ", ")) or "")
end

--- Checks every config("key") argument of a supervisor spec (dca.supervisor_spec) against the repository of
--- host `origin` before anything starts: the key exists and its value fits the parameter. The supervisors
--- read them again at start from each leaf's own host. --> true | nil, the errors (one line each, naming the
--- process, its host, the parameter and the key)
function M.check_spec(hosts, origin, spec, opts)
  local leaves = {}
  local function walk(g)
    for _, ch in ipairs(g.children or {}) do
      if ch.kind == "group" then walk(ch.spec)
      elseif M.has_params(ch.args) then leaves[#leaves + 1] = ch end
    end
  end
  walk(spec)
  if #leaves == 0 then return true end
  local c, err = M.sync(hosts[origin], { key_file = opts and opts.key_file })
  if not c then return nil, sformat("configuration repository of host %s: %s", tostring(origin), tostring(err)) end
  local errors, left = {}, #leaves
  for _, leaf in ipairs(leaves) do
    M.resolve_controller_params(leaf.args, c.client, function(_, rerr)
      if rerr then errors[#errors + 1] = rerr end
      left = left - 1
    end, { process = leaf.path, host = leaf.host, params = leaf.params })
  end
  local finished = c:wait(function() return left == 0 end, c.client.timeout + 1)
  c:close()
  if not finished then
    return nil, sformat("configuration repository of host %s: no answer within %gs", tostring(origin), c.client.timeout)
  end
  if #errors > 0 then table.sort(errors) return nil, table.concat(errors, "\n") end
  return true
end

return M
