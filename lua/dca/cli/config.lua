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
replicated to its peers. Keys are dotted names (door.width, robot.arm.gains.kp). A VALUE is read as a
literal (0.45, true, "text", {1, 2, 3}), never evaluated; a plain word without brackets or quotes (right,
10.0.0.2) is taken as a string, anything else is an error. All the KEY=VALUE of one `set`
are one transaction, acknowledged once the daemon committed it. `log` shows the last N (default 20)
transactions and the conflicts (concurrent writes to one key: the highest stamp wins everywhere, the loser is
kept in the log). The key file is --key, else $DCA_KEY_FILE, else the user's default.]]

local render = config.render

-- Each command: how many words it takes (the command included) and what it does with the client c.
-- run(c, words, values) --> true | nil, err
local COMMANDS = {
  get = { min = 2, max = 2, usage = "get takes one KEY", run = function(c, words)
    local v, e = c:get(words[2])
    if e then return nil, e end
    io.write(render(v), "\n")
    return true
  end },
  set = { min = 2, max = math.huge, usage = "set takes KEY=VALUE...", run = function(c, _, values)
    local r, e = c:set(values)
    if not r then return nil, e end
    io.write(config.format_set(r), "\n")
    return true
  end },
  list = { min = 1, max = 2, usage = "list takes at most one argument", run = function(c, words)
    local entries, e = c:list(words[2])
    if not entries then return nil, e end
    for _, x in ipairs(entries) do io.write(x.key, " = ", render(x.value), "\n") end
    return true
  end },
  log = { min = 1, max = 2, usage = "log takes at most one argument", run = function(c, words)
    local log, e = c:log(tonumber(words[2]) or 20)
    if not log then return nil, e end
    io.write(config.format_log(log), "\n")
    return true
  end },
  status = { min = 1, max = 1, usage = "status takes no argument", run = function(c)
    local s, e = c:status()
    if not s then return nil, e end
    io.write(string.format("replica %s (host %s, %s): %d transactions\n", s.replica, s.host, s.path, s.transactions))
    for _, p in ipairs(s.peers or {}) do
      io.write(string.format("  peer %s%s: %s, %d syncs%s\n", p.address, p.outbound and "" or " (asked us)",
        p.connected and "connected" or "not connected", p.syncs, p.error ~= "" and (", " .. p.error) or ""))
    end
    return true
  end },
}

--- The command of words and, for set, the values to write. --> command, values | nil, usage error
local function command_of(words)
  local cmd = COMMANDS[words[1]]
  if not cmd then return nil, "unknown command '" .. words[1] .. "'" end
  if #words < cmd.min or #words > cmd.max then return nil, cmd.usage end
  local values = {}
  if words[1] == "set" then
    for w = 2, #words do
      local k, v = config.parse_assignment(words[w])
      if not k then return nil, v end
      values[k] = v
    end
  end
  return cmd, values
end

function M.main(argv)
  local words, perr = args.parse(argv, "dca config", { ["--daemon"] = "value", ["--key"] = "value",
    ["-h"] = "flag:help", ["--help"] = "flag:help" }, math.huge)
  if not words then io.stderr:write(perr, "\n") return 2 end
  if words.help then io.write(M.usage, "\n") return 0 end
  if not words[1] then io.stderr:write(M.usage, "\n") return 2 end
  local daemon = words.daemon or os.getenv("DCA_DAEMON")
  if not daemon then
    io.stderr:write("dca config: give the daemon's address with --daemon ADDR (or $DCA_DAEMON)\n")
    return 2
  end
  local cmd, values = command_of(words)
  if not cmd then return args.usage_error("dca config: " .. values, M.usage) end
  local c, err = config.sync(daemon, { key_file = words.key or os.getenv("DCA_KEY_FILE") })
  if not c then
    io.stderr:write("dca config: ", err, "\n")
    return 1
  end
  local ok, cerr = cmd.run(c, words, values)
  c:close()
  if not ok then io.stderr:write("dca config: ", tostring(cerr), "\n") return 1 end
  return 0
end

return M
