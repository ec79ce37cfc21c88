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
-- config.client(daemon) uses an open dca.clients.daemon instead (its event handler is taken over to
-- deliver config_changed events to the watchers; other events still reach the previous handler).
-- Blocking forms for scripts, the REPL and the CLI: config.sync(addr, opts) gives an object whose methods
-- return results directly (running the loop until the reply, bounded by the request timeout).
-- config.resolve_params(args, client, cb) resolves the `config("key")` parameters of a controller (see below).
local core = require "dca.core"
local client = require "dca.clients.config"
local literal = require "dca.literal"
local async = require "dca.async"

local type, ipairs, tostring = type, ipairs, tostring
local sformat = string.format

local M = {}

-- The repository's client (dca.clients.config), under the names it always had here.
M.connect, M.client, M.over_channel, M.sync = client.connect, client.client, client.over_channel, client.sync

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

--- What a `set` reply says: "set 2 keys: transaction 7 of h1".
function M.format_set(r)
  local n = math.tointeger(tonumber(r.keys)) or 0
  local seq = math.tointeger(tonumber(r.seq)) or r.seq
  return sformat("set %d key%s: transaction %s of %s", n, n == 1 and "" or "s", tostring(seq), tostring(r.origin))
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
  local out = {}
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
  -- every key read, then cb with the first failure
  local j = async.join(function(ok, err) if ok then cb(out) else cb(nil, err) end end)
  for i = 1, (args.n or #args) do
    local key = M.param_key(args[i])
    if key then
      local k = j.add()
      client:get(key, function(value, err)
        if err then
          k(nil, describe(i, key) .. ": " .. tostring(err))
        elseif want(i) and not fits(value, want(i)) then
          k(nil, sformat("%s: the value %s is %s, not %s", describe(i, key), render(value),
            math.type(value) == "float" and "a float" or ("a " .. type(value)), want(i) == "integer" and "an integer"
            or ("a " .. want(i))))
        else
          out[i] = value
          k(true)
        end
      end)
    end
  end
  j.close()
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

--- Characters that make a --set VALUE look like code rather than a plain word (see M.parse_assignment).
local CODE_LIKE = "[%(%){}%[%]\"'\\]"

--- Parses "KEY=VALUE" (`dca config set`, `dca run --set`): the key, and the value read by dca.literal (a
--- number, "string", true/false or {table}; nothing is ever evaluated). When VALUE is not a literal it is taken
--- as a string only if it is a plain word: it contains none of ( ) { } [ ] " ' \ (so right, 10.0.0.2,
--- /tmp/x, -x and os.exit are strings); else (os.exit(3), {1,, "open) it is an error naming the column in
--- KEY=VALUE. --> key, value | nil, err (no '=', or a VALUE that looks like code but is not a literal).
function M.parse_assignment(text)
  local key, raw = text:match("^([^=]+)=(.*)$")
  if not key then return nil, "expected KEY=VALUE, got '" .. text .. "'" end
  local v, err, col = literal.read(raw)
  if v ~= nil then return key, v end
  if not raw:find(CODE_LIKE) then return key, raw end
  return nil, sformat("%s: column %d: %s; a value that is not a literal must be a plain word, without brackets, "
    .. "quotes or backslashes", text, #key + 1 + col, err)
end

--- The value of one `key = value` line of a defaults file: raw starts at column col; a trailing `# comment`
--- after the value is ignored (`--` comments too). --> value | nil, the column of the error, err
local function line_value(raw, col)
  local v, stop, ecol = literal.prefix(raw, 1)
  if v == nil then return nil, col + ecol - 1, stop end
  if stop <= #raw and raw:sub(stop, stop) ~= "#" then
    return nil, col + stop - 1, sformat("unexpected '%s' after the value", raw:sub(stop, stop))
  end
  return v
end

--- Reads a file of configuration defaults: one `key = value` per line, the value a literal read by
--- dca.literal (0.45, 75, true, "right", {1, 2}; never evaluated); `#` or `--` starts a comment.
--- --> { { key =, value =, line = }, ... } (in file order) | nil, "FILE:LINE:COL: what is wrong", the column
--- being that of the offending character.
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
        return fail(#lead + 1, "'" .. key .. "' is not a dotted key (like arm.stop_distance)")
      end
      if raw == "" then return fail(col, "no value for " .. key) end
      local v, ecol, verr = line_value(raw, col)
      if v == nil then
        return fail(ecol, sformat("the value of %s is not a literal (a number, true/false, a \"string\" or a "
          .. "{table} of those; nothing is evaluated): %s", key, verr))
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

--- Checks every config("key") argument of a supervisor spec (dca.supervisor.spec) against the repository of
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
  local errors, all_read = {}, false
  local j = async.join(function() all_read = true end)
  for _, leaf in ipairs(leaves) do
    local k = j.add()
    M.resolve_controller_params(leaf.args, c.client, function(_, rerr)
      if rerr then errors[#errors + 1] = rerr end
      k(true)
    end, { process = leaf.path, host = leaf.host, params = leaf.params })
  end
  j.close()
  local finished = c:wait(function() return all_read end, c.client.timeout + 1)
  c:close()
  if not finished then
    return nil, sformat("configuration repository of host %s: no answer within %gs", tostring(origin), c.client.timeout)
  end
  if #errors > 0 then table.sort(errors) return nil, table.concat(errors, "\n") end
  return true
end

return M
