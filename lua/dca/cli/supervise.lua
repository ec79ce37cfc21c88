-- `dca supervise --name PATH --daemon ADDR [--key FILE]`: one DCAS (a process-group instance), started by the
-- daemon of its group's host on behalf of the parent supervisor. It listens for its parent on a control
-- channel, registers PATH with its daemon (endpoint `control`), receives its group's spec in a "configure"
-- request, starts and connects its children, and runs its expression on "run". It exits when its parent
-- asks (shutdown) or goes away (everything it started is stopped first).
local core = require "dca.core"
local supervisor = require "dca.supervisor"
local srt = require "dca.supervisor.net"

local USAGE = "dca supervise --name PATH --daemon ADDR [--key FILE] [--listen ADDR]"

local function parse(args)
  local o = {}
  local i = 1
  while i <= #args do
    local a = args[i]
    local k = a:match("^%-%-(%w+)$")
    if k and args[i + 1] then o[k] = args[i + 1] i = i + 2
    else return nil, "unexpected argument '" .. a .. "'" end
  end
  if not o.name or not o.daemon then return nil, "--name and --daemon are required" end
  return o
end

local function main(args)
  if not core.loop or not core.connect then
    io.stderr:write("dca supervise: this dca has no control plane (dca.core.loop/connect)\n")
    return 3
  end
  local o, err = parse(args)
  if not o then io.stderr:write("dca supervise: ", err, "\nusage: ", USAGE, "\n") return 2 end
  local key = o.key or os.getenv("DCA_KEY_FILE")
  local loop = core.loop()
  local exit_code
  local sup, parent, rt
  local function finish(code)
    if exit_code then return end
    exit_code = code
    if rt then rt.close() end
    loop:stop()
  end
  local followers = {}   -- consoles (`dca repl PATH`) following this supervisor's transition lines
  local function line_out(line)
    srt.to_followers(followers, line)
    if os.getenv("DCA_SUPERVISE_VERBOSE") then io.stderr:write(line, "\n") end
  end
  -- The first channel whose first request is "configure" is the parent; any other is a console.
  local function on_channel(ch)
    ch:on_message(function(msg, id)
      if (id or 0) == 0 then return end
      if ch ~= parent then
        if parent or msg.type ~= "configure" then srt.console(ch, id, msg, sup, followers) return end
        parent = ch
        ch:on_close(function()
          -- the parent is gone: stop everything this supervisor started, then exit
          if sup then sup:shutdown(function() finish(1) end) else finish(1) end
          core.after(30, function() finish(1) end)
        end)
      end
      if msg.type == "configure" and not sup then
        local own_host
        for h, a in pairs(msg.hosts or {}) do if a == o.daemon then own_host = h end end
        rt = srt.new({ hosts = msg.hosts, key = key, exe = "dca", daemon_host = own_host,
          timeouts = msg.timeouts,
          report = function(m)
            ch:send(m)
            if m.type == "log" then srt.to_followers(followers, m.line) end
          end,
          log = line_out })
        sup = supervisor.new(msg.spec, rt, { progress = msg.progress, timeouts = msg.timeouts, hosts = msg.hosts })
        sup.hosts = msg.hosts
        rt.bind(sup)
      end
      if not sup then srt.reply(ch, id, { type = "error", reason = "not configured yet" }) return end
      if msg.type == "configure" then
        sup:handle(msg, function(r) srt.reply(ch, id, r) end)
        return
      end
      sup:handle(msg, function(r)
        srt.reply(ch, id, r)
        if msg.type == "shutdown" then core.after(0.05, function() finish(0) end) end
      end)
    end)
    ch:on_close(function() followers[ch] = nil end)
  end
  -- listen on the daemon's IP (another host's supervisor must reach it), a free port
  local ip = o.daemon:match("^%[(.-)%]:%d+$") and ("[" .. o.daemon:match("^%[(.-)%]") .. "]")
    or o.daemon:match("^([%d%.]+):%d+$") or "127.0.0.1"
  local listener, lerr = core.listen(o.listen or (ip .. ":0"), srt.key_opts(key), on_channel)
  if not listener then io.stderr:write("dca supervise: listen: ", tostring(lerr), "\n") return 1 end
  core.connect(o.daemon, srt.key_opts(key), function(dch, cerr)
    if not dch then io.stderr:write("dca supervise: daemon ", o.daemon, ": ", tostring(cerr), "\n") finish(1) return end
    dch:request({ type = "register", name = o.name,
                  endpoints = { control = listener:address(), pid = core.pid() } }, 5,
      function(r, rerr)
        if not r or r.type == "error" then
          io.stderr:write("dca supervise: register ", o.name, ": ", tostring(r and r.reason or rerr), "\n")
          finish(1)
        end
      end)
    dch:on_close(function() if sup then sup:shutdown(function() finish(1) end) else finish(1) end end)
  end)
  -- SIGTERM (its daemon stopping it, or a person): what it started goes first, then it exits (bounded)
  core.on_signal(function()
    if sup then sup:shutdown(function() finish(0) end) else finish(0) end
    core.after(30, function() finish(1) end)
  end)
  -- a parent that never comes is a failed start: give up after the configure timeout
  core.after(supervisor.timeouts.configure, function() if not parent then finish(1) end end)
  loop:run()
  return exit_code or 0
end

return { summary = "run one supervisor (DCAS) of a process group; started by a daemon", usage = USAGE, main = main }
