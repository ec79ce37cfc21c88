-- `dca config get|set|list|log|status`: the configuration repository of a running daemon.
local config = require "dca.config"

local M = {}

M.summary = "the configuration repository (replicated between daemons): get, set, list, log"
M.usage = [[usage: dca config get KEY [--daemon ADDR] [--key FILE]
       dca config set KEY=VALUE... [--daemon ADDR] [--key FILE]
       dca config list [PREFIX] [--daemon ADDR] [--key FILE]
       dca config log [N] [--daemon ADDR] [--key FILE]
       dca config status [--daemon ADDR] [--key FILE]

Reads and writes the configuration repository held by the daemon at ADDR (--daemon, else $DCA_DAEMON) and
replicated to its peers. Keys are dotted names (door.width, robot.arm.gains.kp). A VALUE is read as a Lua
literal (0.45, true, "text", {1, 2, 3}); anything else is taken as a string. All the KEY=VALUE of one `set`
are one transaction, acknowledged once the daemon committed it. `log` shows the last N (default 20)
transactions and the conflicts (concurrent writes to one key: the highest stamp wins everywhere, the loser is
kept in the log). The key file is --key, else $DCA_KEY_FILE, else the user's default.]]

local function render(v, depth)
  depth = depth or 0
  local t = type(v)
  if t == "string" then return string.format("%q", v) end
  if t == "number" then
    if math.type(v) == "float" and v == math.floor(v) and v >= -1e15 and v <= 1e15 then return string.format("%.1f", v) end
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
M.render = render

local function stamp_text(s)
  if type(s) ~= "table" then return "?" end
  return string.format("%s.%d@%s", os.date("!%Y-%m-%dT%H:%M:%S", math.floor(s.ms / 1000)) ..
    string.format(".%03dZ", s.ms % 1000), s.n or 0, tostring(s.origin))
end
M.stamp_text = stamp_text

--- The text of a `config_log` reply: the replica, its transactions and its conflicts, newest first.
function M.format_log(log)
  local out = { string.format("replica %s (host %s, %s): %d transactions", log.replica, log.host, log.path,
    log.transactions), "transactions, newest first:" }
  for _, t in ipairs(log.txns or {}) do
    local ws = {}
    for _, w in ipairs(t.writes or {}) do ws[#ws + 1] = w.key .. " = " .. render(w.value) end
    out[#out + 1] = string.format("  %s #%d  %s  %s", t.origin, t.seq, stamp_text(t.stamp), table.concat(ws, ", "))
  end
  out[#out + 1] = "conflicts, newest first:" .. (#(log.conflicts or {}) == 0 and " none" or "")
  for _, x in ipairs(log.conflicts or {}) do
    out[#out + 1] = string.format("  %s: %s (%s) won over %s (%s)", x.key, render(x.winner.value),
      stamp_text(x.winner.stamp), render(x.loser.value), stamp_text(x.loser.stamp))
  end
  return table.concat(out, "\n")
end

--- Parses "KEY=VALUE": the key, and the value as a Lua literal (else the text itself). nil, err when no '='.
function M.parse_assignment(text)
  local key, raw = text:match("^([^=]+)=(.*)$")
  if not key then return nil, "expected KEY=VALUE, got '" .. text .. "'" end
  local chunk = load("return " .. raw, "=value", "t", {})
  if chunk then
    local ok, v = pcall(chunk)
    if ok and v ~= nil and type(v) ~= "function" then return key, v end
  end
  return key, raw
end

function M.main(args)
  local words, daemon, key = {}, nil, nil
  local i, n = 1, args.n or #args
  while i <= n do
    local a = args[i]
    if a == "--daemon" or a == "--key" then
      if i == n then io.stderr:write("dca config: ", a, " needs a value\n") return 2 end
      if a == "--daemon" then daemon = args[i + 1] else key = args[i + 1] end
      i = i + 1
    elseif a == "-h" or a == "--help" then
      io.write(M.usage, "\n")
      return 0
    else
      words[#words + 1] = a
    end
    i = i + 1
  end
  local cmd = words[1]
  if not cmd then io.stderr:write(M.usage, "\n") return 2 end
  daemon = daemon or os.getenv("DCA_DAEMON")
  if not daemon then
    io.stderr:write("dca config: give the daemon's address with --daemon ADDR (or $DCA_DAEMON)\n")
    return 2
  end
  local usage_error
  if cmd == "get" and #words ~= 2 then usage_error = "get takes one KEY"
  elseif cmd == "set" and #words < 2 then usage_error = "set takes KEY=VALUE..."
  elseif (cmd == "list" or cmd == "log") and #words > 2 then usage_error = cmd .. " takes at most one argument"
  elseif cmd == "status" and #words ~= 1 then usage_error = "status takes no argument"
  elseif cmd ~= "get" and cmd ~= "set" and cmd ~= "list" and cmd ~= "log" and cmd ~= "status" then
    usage_error = "unknown command '" .. cmd .. "'"
  end
  local values = {}
  if cmd == "set" and not usage_error then
    for w = 2, #words do
      local k, v = M.parse_assignment(words[w])
      if not k then usage_error = v break end
      values[k] = v
    end
  end
  if usage_error then
    io.stderr:write("dca config: ", usage_error, "\n", M.usage, "\n")
    return 2
  end

  local c, err = config.sync(daemon, { key_file = key or os.getenv("DCA_KEY_FILE") })
  if not c then
    io.stderr:write("dca config: ", err, "\n")
    return 1
  end
  local function fail(e)
    io.stderr:write("dca config: ", tostring(e), "\n")
    c:close()
    return 1
  end
  if cmd == "get" then
    local v, e = c:get(words[2])
    if e then return fail(e) end
    io.write(render(v), "\n")
  elseif cmd == "set" then
    local r, e = c:set(values)
    if not r then return fail(e) end
    io.write(string.format("set %d key%s: transaction %d of %s\n", r.keys, r.keys == 1 and "" or "s", r.seq, r.origin))
  elseif cmd == "list" then
    local entries, e = c:list(words[2])
    if not entries then return fail(e) end
    for _, x in ipairs(entries) do io.write(x.key, " = ", render(x.value), "\n") end
  elseif cmd == "log" then
    local log, e = c:log(tonumber(words[2]) or 20)
    if not log then return fail(e) end
    io.write(M.format_log(log), "\n")
  elseif cmd == "status" then
    local s, e = c:status()
    if not s then return fail(e) end
    io.write(string.format("replica %s (host %s, %s): %d transactions\n", s.replica, s.host, s.path, s.transactions))
    for _, p in ipairs(s.peers or {}) do
      io.write(string.format("  peer %s%s: %s, %d syncs%s\n", p.address, p.outbound and "" or " (asked us)",
        p.connected and "connected" or "not connected", p.syncs, p.error ~= "" and (", " .. p.error) or ""))
    end
  end
  c:close()
  return 0
end

return M
