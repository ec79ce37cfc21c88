-- `dca config get|set|list|log|status`: the configuration repository of a running daemon.
local args = require "dca.cli.args"
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

local render = config.render
M.render, M.format_log = config.render, config.format_log  -- kept for callers not yet on dca.config

M.parse_assignment = config.parse_assignment  -- kept for callers not yet on dca.config.parse_assignment

function M.main(argv)
  local o, perr = args.parse(argv, "dca config", { ["--daemon"] = "value", ["--key"] = "value",
    ["-h"] = "flag:help", ["--help"] = "flag:help" }, math.huge)
  if not o then io.stderr:write(perr, "\n") return 2 end
  if o.help then io.write(M.usage, "\n") return 0 end
  local words, daemon, key = o, o.daemon, o.key
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
      local k, v = config.parse_assignment(words[w])
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
    io.write(config.format_log(log), "\n")
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
