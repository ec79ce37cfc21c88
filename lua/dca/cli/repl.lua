-- `dca repl PATH|ADDR`: a console on a running supervisor over the authenticated control plane.
-- The supervisor evaluates each line (dca.supervisor.console: Lua like the `lua` console, plus tree(), status(),
-- expr(), log(), event(), abort(), restart(), activate(), deactivate(), reload(), help()). Line editing,
-- history (~/.dca_history) and Tab completion of commands and process paths come from libedit.
local core = require "dca.core"
local console, args_mod = require "dca.clients.console", require "dca.cli.args"

local M = {}

M.summary = "a console on a running supervisor (tree, status, events, restart, reload, any Lua)"
M.usage = [[usage: dca repl PATH|ADDR [--daemon ADDR] [--key FILE]

Opens a console on the supervisor of the group PATH (e.g. main.dooropensyst, looked up at the daemon given by
--daemon or $DCA_DAEMON) or at the control address ADDR (127.0.0.1:PORT). Type help() for the commands;
any other Lua runs inside the supervisor. Ctrl-D leaves the console; the system keeps running.
restart(path) of a leaf starts its process anew from what is on disk now (rebuild a controller, then restart
it) while the rest of the system runs. A leaf that shares its process (dca run --placement group|host) keeps
the code that process loaded: its restart is refused when its package changed on disk.]]

local HISTORY = (os.getenv("HOME") or ".") .. "/.dca_history"

local function looks_like_address(s)
  return s:match("^unix:") or s:match("^/") or s:match("^[%w%.%-%[%]:]+:%d+$")
end

-- Runs the loop until fn's callback has been called (bounded by `timeout`). --> what it was called with
local function await(loop, timeout, fn)
  local res
  fn(function(...) res = table.pack(...) end)
  loop:run_until(function() return res ~= nil end, timeout)
  if not res then return nil, "no answer within " .. timeout .. "s" end
  return table.unpack(res, 1, res.n)
end

-- The control address of the supervisor `target` (an address, or a path looked up at `daemon`).
-- --> addr | nil, error line, exit code
local function find(loop, target, daemon, key)
  if looks_like_address(target) then return target end
  if not daemon then return nil, "to find '" .. target .. "' give --daemon ADDR (or $DCA_DAEMON)", 2 end
  local addr, err = await(loop, 20, function(k) console.find(daemon, target, { key_file = key }, k) end)
  if not addr then return nil, err, 1 end
  return addr
end

M.await, M.find = await, find  -- (dca upgrade reaches a supervisor the same way)

-- A console session on the supervisor's channel.
local Session = {}
Session.__index = Session

-- The evaluation of `line`, answered before the loop returns (bounded). --> reply | nil, err
function Session:eval(line)
  return await(self.loop, console.EVAL_TIMEOUT + 1, function(k) self.client:eval(line, k) end)
end

-- stdin is a pipe or a file: one answer per line, in order, nothing asynchronous.
function Session:lines()
  local prompt = "dca> "
  while true do
    local line = core.readline(prompt)
    if line == nil then break end
    core.add_history(line)
    local r, e = self:eval(line)
    if not r then
      io.stderr:write("no answer: ", tostring(e), "\n")
      if self.closed then break end
    else
      if r.output and r.output ~= "" then io.stdout:write(r.output, "\n") end
      prompt = r.more and "  >> " or "dca> "
    end
  end
end

-- One line typed at the terminal: evaluated (no prompt meanwhile; lines arriving simply print), the answer,
-- then a fresh prompt. nil (Ctrl-D) leaves.
function Session:on_line(line)
  if line == nil then self.quit = true return end
  core.readline_remove()
  if line:match("%S") then core.add_history(line) end
  self.client:eval(line, function(r, e)
    if not r then io.stdout:write("no answer: ", tostring(e), "\n")
    else
      self.prompt = r.more and "  >> " or "dca> "
      if r.output and r.output ~= "" then io.stdout:write(r.output, "\n") end
    end
    io.stdout:flush()
    core.readline_install(self.prompt, function(l) self:on_line(l) end)
  end)
end

-- A terminal: the supervisor's transition lines arrive while a line is being typed; each is printed above the
-- prompt, which is drawn again with the typed text (core.readline_print).
function Session:terminal()
  self.prompt = "dca> "
  self.client:follow(core.readline_print)
  core.readline_install(self.prompt, function(l) self:on_line(l) end)
  -- the loop runs in slices; between them the terminal's input is fed to the line editor (a person's
  -- keystrokes: 20 ms is below what anyone notices)
  while not self.quit and not self.closed do
    self.loop:run_until(function() return self.quit or self.closed ~= nil end, 0.02)
    core.readline_poll()
  end
  core.readline_remove()
  if self.closed then io.stderr:write("\nthe supervisor closed the console: ", tostring(self.closed), "\n") end
end

-- Connects to the console at `addr`. --> session | nil, err
local function open(loop, addr, key)
  local c, err = await(loop, 10, function(k) console.connect(addr, { key_file = key }, k) end)
  if not c then return nil, err end
  local s = setmetatable({ loop = loop, client = c }, Session)
  c:on_close(function(reason) s.closed = reason or "closed" end)
  return s
end

-- The console, from the first line to Ctrl-D (or the supervisor's leaving). --> exit code
function Session:run(target, addr)
  core.read_history(HISTORY)
  -- Tab: asked from inside the line editor, outside the loop (never a nested run of it)
  core.set_completer(function(word)
    local r = await(self.loop, console.COMPLETE_TIMEOUT + 1, function(k) self.client:complete(word, k) end)
    return r and r.candidates or {}
  end)
  io.stdout:write("connected to ", target, " (", addr, "); help() lists the commands, Ctrl-D leaves\n")
  if core.readline_install and core.readline_print and os.execute("test -t 0 && test -t 1") then self:terminal()
  else self:lines() end
  core.write_history(HISTORY)
  local lost = self.closed  -- the supervisor went away (1), or the person left (0)
  self.client:close()
  io.stdout:write("\n")
  return lost and 1 or 0
end

function M.main(argv)
  if not core.loop or not core.connect then
    io.stderr:write("dca repl: this dca has no control plane (dca.core.loop/connect)\n")
    return 3
  end
  local o, err = args_mod.parse(argv, "dca repl", { ["--daemon"] = "value", ["--key"] = "value" })
  if not o then io.stderr:write(err, "\n", M.usage, "\n") return 2 end
  local target = o[1]
  if not target then io.stderr:write(M.usage, "\n") return 2 end
  local key, loop = o.key or os.getenv("DCA_KEY_FILE"), core.loop()
  local addr, ferr, code = find(loop, target, o.daemon or os.getenv("DCA_DAEMON"), key)
  if not addr then io.stderr:write("dca repl: ", ferr, "\n") return code end
  local session, cerr = open(loop, addr, key)
  if not session then io.stderr:write("dca repl: ", addr, ": ", tostring(cerr), "\n") return 1 end
  return session:run(target, addr)
end

return M
