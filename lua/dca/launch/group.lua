-- dca.launch.group: the process of one group's supervisor (`dca supervise`), without its argv: it listens for
-- its parent on a control channel, registers its path with its daemon (endpoint `control`), receives its
-- group's spec in a "configure" request and builds its supervisor (dca.launch.start.tree), answers consoles,
-- and exits when its parent asks (shutdown) or goes away, or on SIGTERM (what it started is stopped first).
--
--   local code = require("dca.launch.group").main(o, out)
--   o = { name = PATH, daemon = ADDR, key = FILE, listen = ADDR }
--   out = { error = fn(text), line = fn(text), verbose = bool }  -- with verbose, its transition lines to line
local core, clients = require "dca.core", require "dca.clients"
local async = require "dca.async"
local supervisor, srt = require "dca.supervisor", require "dca.supervisor.net"
local start = require "dca.launch.start"

local M = {}

local pairs, tostring = pairs, tostring

-- One supervisor process: its options, loop, parent channel, consoles following it, supervisor and runtime.
local Proc = {}
Proc.__index = Proc

-- Exits with `code`. On simulated time it leaves the clock in order (its last counts said) unless `orphaned`:
-- its parent or its daemon went away (its host lost, as the parent sees it). Then its channel to the clock
-- master just closes and the master counts it as a lost supervisor, whose events nobody will receive
-- (docs/time.md): said in order, its counts would lack the exits of its lost leaves, and the barrier would
-- wait for them forever.
function Proc:finish(code, orphaned)
  if self.exit_code then return end
  self.exit_code = code
  local function stop()
    if self.rt then self.rt.close() end
    self.loop:stop()
  end
  if self.rt and not orphaned then self.rt.leave_clock(stop) else stop() end
end

-- Everything this supervisor started is stopped, then it exits with `code` (with 1 when that takes 30 s).
function Proc:wind_down(code, orphaned)
  if self.sup then self.sup:shutdown(function() self:finish(code, orphaned) end) else self:finish(code, orphaned) end
  core.after(30, function() self:finish(1, orphaned) end)
end

-- The tree of this group, on the "configure" request of the parent channel `ch` (dca.launch.start.tree).
function Proc:configure(ch, msg)
  local own_host
  for h, a in pairs(msg.hosts or {}) do if a == self.o.daemon then own_host = h end end
  local ctx = { spec = msg.spec, hosts = msg.hosts, key = self.key, exe = "dca", to_parent = true,
    report = function(m)
      ch:send(m)
      if m.type == "log" then srt.to_followers(self.followers, m.line) end
    end,
    log = function(line)
      srt.to_followers(self.followers, line)
      if self.out.verbose then self.out.line(line) end
    end }
  self.sup = start.tree(ctx, own_host, { progress = msg.progress, timeouts = msg.timeouts, placement = msg.placement })
  self.rt = ctx.rt
end

-- A request on channel `ch`: the first channel whose first request is "configure" is the parent; any other
-- is a console.
function Proc:on_request(ch, msg, id)
  if (id or 0) == 0 then return end
  if ch ~= self.parent then
    if self.parent or msg.type ~= "configure" then srt.console(ch, id, msg, self.sup, self.followers) return end
    self.parent = ch
    -- the parent is gone: orphaned, unless it asked for the shutdown first (then it closes after the answer)
    ch:on_close(function() self:wind_down(1, not self.asked_down) end)
  end
  if msg.type == "shutdown" then self.asked_down = true end  -- in order: it leaves the clock saying its counts
  if msg.type == "configure" and not self.sup then self:configure(ch, msg) end
  if not self.sup then srt.reply(ch, id, { type = "error", reason = "not configured yet" }) return end
  self.sup:handle(msg, function(r)
    srt.reply(ch, id, r)
    if msg.type == "shutdown" then core.after(0.05, function() self:finish(0) end) end
  end)
end

-- Listens on the daemon's IP (another host's supervisor must reach it), a free port. --> listener | nil, err
function Proc:listen()
  local d = self.o.daemon
  local ip = d:match("^%[(.-)%]:%d+$") and ("[" .. d:match("^%[(.-)%]") .. "]") or d:match("^([%d%.]+):%d+$")
    or "127.0.0.1"
  return core.listen(self.o.listen or (ip .. ":0"), clients.key_opts(self.key), function(ch)
    ch:on_message(function(msg, id) self:on_request(ch, msg, id) end)
    ch:on_close(function() self.followers[ch] = nil end)
  end)
end

-- Registers this supervisor's path with its daemon; the daemon's loss ends it.
function Proc:register(listener)
  local o = self.o
  require("dca.clients.daemon").connect(o.daemon, clients.key_opts(self.key), function(d, cerr)
    if not d then self.out.error("daemon " .. o.daemon .. ": " .. tostring(cerr)) self:finish(1) return end
    d:register(o.name, { control = listener:address(), pid = core.pid() }, function(r, rerr)
      local ok, why = async.outcome(r, rerr)
      if not ok then
        self.out.error("register " .. o.name .. ": " .. why)
        self:finish(1)
      end
    end)
    d:on_close(function() self:wind_down(1, true) end)  -- its daemon is gone
  end)
end

--- Runs the supervisor process of group o.name until it exits. --> exit code
function M.main(o, out)
  local p = setmetatable({ o = o, out = out, key = o.key or os.getenv("DCA_KEY_FILE"), loop = core.loop(),
                           followers = {} }, Proc)
  local listener, lerr = p:listen()
  if not listener then out.error("listen: " .. tostring(lerr)) return 1 end
  p:register(listener)
  -- SIGTERM (its daemon stopping it, or a person): what it started goes first, then it exits (bounded)
  core.on_signal(function() p:wind_down(0) end)
  -- a parent that never comes is a failed start: give up after the configure timeout
  core.after(supervisor.timeouts.configure, function() if not p.parent then p:finish(1) end end)
  p.loop:run()
  return p.exit_code or 0
end

return M
