-- dca.clients.daemon: a thin client of a `dca daemon` over a control channel (dca.core).
--
--   local daemon = require "dca.clients.daemon"
--   daemon.connect("127.0.0.1:4000", { timeout = 5 }, function(d, err)
--     if not d then error(err) end
--     d:spawn({ "dca", "node", "--type", "Gain" }, { name = "/sys/g", on_exit = function(ev) ... end },
--       function(reply, err) ... end)          -- reply = { child =, pid =, host = }
--     d:lookup("/sys/g", { wait_ms = 500 }, function(reply, err) ... end)   -- reply = { name, endpoints, host }
--   end)
--
-- Every call takes a callback cb(reply, err) that runs exactly once, from the loop: the reply table, or nil and
-- the reason (the daemon's error, a timeout, or the channel's close). A nil callback ignores the result.
-- Exit events: { child =, pid =, name =, host =, code = N } or { ..., signal = "SIGSEGV" }; given to the
-- spawn's on_exit and to the handler set with client:on_exit(fn).
local core = require "dca.core"

local setmetatable, type = setmetatable, type

local M = {}

local Client = {}
Client.__index = Client

local function ignore() end

--- Connects to the daemon at `addr`. `opts`: those of core.connect (key, key_file, timeout for the handshake)
--- plus `request_timeout` (seconds, default 5) for each request. Calls cb(client) or cb(nil, err).
function M.connect(addr, opts, cb)
  opts = opts or {}
  core.connect(addr, opts, function(ch, err)
    if not ch then return cb(nil, err) end
    local self = setmetatable({
      channel = ch,
      address = addr,
      timeout = opts.request_timeout or 5,
      exit_handlers = {},
    }, Client)
    ch:on_message(function(msg)
      if msg.type == "exit" then
        local h = self.exit_handlers[msg.child]
        self.exit_handlers[msg.child] = nil
        if h then h(msg) end
        if self.exit_fn then self.exit_fn(msg) end
      elseif self.event_fn then
        self.event_fn(msg)
      end
    end)
    ch:on_close(function(reason)
      self.closed = reason
      if self.close_fn then self.close_fn(reason) end
    end)
    cb(self)
  end)
end

function Client:request(msg, timeout, cb)
  self.channel:request(msg, timeout or self.timeout, cb or ignore)
end

--- Starts argv on the daemon's host. opts: name (for reports), on_exit(ev), timeout (s).
function Client:spawn(argv, opts, cb)
  opts = opts or {}
  self:request({ type = "spawn", argv = argv, name = opts.name }, opts.timeout, function(reply, err, full)
    if reply and opts.on_exit then self.exit_handlers[reply.child] = opts.on_exit end
    if cb then cb(reply, err, full) end
  end)
end

--- Sends `signal` ("SIGTERM" when nil, a name such as "SIGKILL", or a number) to a child's process group.
function Client:kill(child, signal, cb)
  self:request({ type = "kill", child = child, signal = signal }, nil, cb)
end

--- Looks `name` up here and at the daemon's peers. opts: wait_ms (wait that long for it to be registered),
--- timeout (s; default: wait_ms plus the client's request timeout).
function Client:lookup(name, opts, cb)
  opts = opts or {}
  local wait_ms = opts.wait_ms or 0
  self:request({ type = "lookup", name = name, wait_ms = wait_ms }, opts.timeout or (wait_ms / 1000 + self.timeout), cb)
end

--- Registers `name` with `endpoints` (a table) for as long as this client's channel is open.
function Client:register(name, endpoints, cb)
  self:request({ type = "register", name = name, endpoints = endpoints or {} }, nil, cb)
end

function Client:unregister(name, cb)
  self:request({ type = "unregister", name = name }, nil, cb)
end

function Client:ping(cb) self:request({ type = "ping" }, nil, cb) end
function Client:status(cb) self:request({ type = "status" }, nil, cb) end

--- fn(ev) for every exit event (after the spawn's own on_exit).
function Client:on_exit(fn) self.exit_fn = fn end
--- fn(msg) for any other event the daemon sends.
function Client:on_event(fn) self.event_fn = fn end
--- fn(reason) when the channel closes.
function Client:on_close(fn)
  if self.closed and type(fn) == "function" then
    core.after(0, function() fn(self.closed) end)
  else
    self.close_fn = fn
  end
end

function Client:close(reason) self.channel:close(reason) end
function Client:is_open() return self.channel:is_open() end

return M
