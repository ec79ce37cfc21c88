-- `dca repl PATH|ADDR`: a console on a running supervisor over the authenticated control plane.
-- The supervisor evaluates each line (dca.supervisor.console: Lua like the `lua` console, plus tree(), status(),
-- expr(), log(), event(), abort(), restart(), activate(), deactivate(), reload(), help()). Line editing,
-- history (~/.dca_history) and Tab completion of commands and process paths come from libedit.
local core = require "dca.core"

local M = {}

M.summary = "a console on a running supervisor (tree, status, events, restart, reload, any Lua)"
M.usage = [[usage: dca repl PATH|ADDR [--daemon ADDR] [--key FILE]

Opens a console on the supervisor of the group PATH (e.g. main.dooropensyst, looked up at the daemon given by
--daemon or $DCA_DAEMON) or at the control address ADDR (127.0.0.1:PORT). Type help() for the commands;
any other Lua runs inside the supervisor. Ctrl-D leaves the console; the system keeps running.]]

local HISTORY = (os.getenv("HOME") or ".") .. "/.dca_history"

local function looks_like_address(s)
  return s:match("^unix:") or s:match("^/") or s:match("^[%w%.%-%[%]:]+:%d+$")
end

function M.main(args)
  if not core.loop or not core.connect then
    io.stderr:write("dca repl: this dca has no control plane (dca.core.loop/connect)\n")
    return 3
  end
  local target, daemon, key
  local i, n = 1, args.n or #args
  while i <= n do
    local a = args[i]
    if a == "--daemon" then daemon = args[i + 1] i = i + 1
    elseif a == "--key" then key = args[i + 1] i = i + 1
    elseif a:sub(1, 1) == "-" or target then io.stderr:write("dca repl: unexpected argument '", a, "'\n", M.usage, "\n") return 2
    else target = a end
    i = i + 1
  end
  if not target then io.stderr:write(M.usage, "\n") return 2 end
  key = key or os.getenv("DCA_KEY_FILE")
  daemon = daemon or os.getenv("DCA_DAEMON")
  local loop = core.loop()
  local function wait(pred, timeout)
    return loop:run_until(pred, timeout)
  end

  local addr = looks_like_address(target) and target or nil
  if not addr then
    if not daemon then io.stderr:write("dca repl: to find '", target, "' give --daemon ADDR (or $DCA_DAEMON)\n") return 2 end
    local dch, derr
    core.connect(daemon, { key_file = key }, function(c, e) dch, derr = c, e or "" end)
    wait(function() return dch or derr end, 10)
    if not dch then io.stderr:write("dca repl: daemon ", daemon, ": ", tostring(derr), "\n") return 1 end
    local r, rerr
    dch:request({ type = "lookup", name = target, wait_ms = 2000 }, 3, function(m, e) r, rerr = m, e or "" end)
    wait(function() return r or rerr end, 5)
    local ep = r and (r.endpoints or r)
    if not ep or not ep.control then
      io.stderr:write("dca repl: no supervisor '", target, "': ", tostring(r and r.reason or rerr), "\n")
      return 1
    end
    addr = ep.control
    dch:close()
  end
  local ch, cerr
  core.connect(addr, { key_file = key }, function(c, e) ch, cerr = c, e or "" end)
  wait(function() return ch or cerr end, 10)
  if not ch then io.stderr:write("dca repl: ", addr, ": ", tostring(cerr), "\n") return 1 end
  local closed
  ch:on_close(function(reason) closed = reason or "closed" end)
  ch:on_message(function() end)

  local function ask(msg, timeout)
    local r, e
    ch:request(msg, timeout, function(m, err) r, e = m, err or "" end)
    wait(function() return r or e end, timeout + 1)
    return r, e
  end
  core.read_history(HISTORY)
  -- Tab: asked from inside the line editor, outside the loop (never a nested run of it)
  core.set_completer(function(word)
    local r = ask({ type = "complete", prefix = word }, 2)
    return r and r.candidates or {}
  end)
  io.stdout:write("connected to ", target, " (", addr, "); help() lists the commands, Ctrl-D leaves\n")
  local interactive = core.readline_install and core.readline_print and os.execute("test -t 0 && test -t 1")
  if not interactive then
    -- stdin is a pipe or a file: one answer per line, in order, nothing asynchronous
    local prompt = "dca> "
    while true do
      local line = core.readline(prompt)
      if line == nil then break end
      core.add_history(line)
      local r, e = ask({ type = "repl", line = line }, 60)
      if not r then
        io.stderr:write("no answer: ", tostring(e), "\n")
        if closed then break end
      else
        if r.output and r.output ~= "" then io.stdout:write(r.output, "\n") end
        prompt = r.more and "  >> " or "dca> "
      end
    end
  else
    -- a terminal: the supervisor's transition lines arrive while a line is being typed; each is printed
    -- above the prompt, which is drawn again with the typed text (core.readline_print)
    local quit = false
    local prompt = "dca> "
    ch:on_message(function(msg) if msg.type == "log" and msg.line then core.readline_print(msg.line) end end)
    ch:request({ type = "follow" }, 10, function() end)
    -- while a line is evaluated there is no prompt (lines arriving meanwhile simply print); the answer,
    -- then a fresh prompt
    local on_line
    function on_line(line)
      if line == nil then quit = true return end
      core.readline_remove()
      if line:match("%S") then core.add_history(line) end
      ch:request({ type = "repl", line = line }, 60, function(r, e)
        if not r then io.stdout:write("no answer: ", tostring(e), "\n")
        else
          prompt = r.more and "  >> " or "dca> "
          if r.output and r.output ~= "" then io.stdout:write(r.output, "\n") end
        end
        io.stdout:flush()
        core.readline_install(prompt, on_line)
      end)
    end
    core.readline_install(prompt, on_line)
    -- the loop runs in slices; between them the terminal's input is fed to the line editor (a person's
    -- keystrokes: 20 ms is below what anyone notices)
    while not quit and not closed do
      loop:run_until(function() return quit or closed ~= nil end, 0.02)
      core.readline_poll()
    end
    core.readline_remove()
    if closed then io.stderr:write("\nthe supervisor closed the console: ", tostring(closed), "\n") end
  end
  core.write_history(HISTORY)
  local lost = closed  -- the supervisor went away (1), or the person left (0)
  ch:close()
  io.stdout:write("\n")
  return lost and 1 or 0
end

return M
