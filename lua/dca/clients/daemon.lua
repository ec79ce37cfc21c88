-- dca.clients.daemon: the client of a `dca daemon` over a control channel (dca.core).
--
--   local daemon = require "dca.clients.daemon"
--   daemon.connect("127.0.0.1:4000", { key_file = KEY }, function(d, err)
--     if not d then error(err) end
--     d:spawn({ "dca", "node", "--type", "Gain" }, { name = "/sys/g", on_exit = function(ev) ... end },
--       function(reply, err) ... end)          -- reply = { child =, pid =, host = }
--     d:lookup("/sys/g", { wait_ms = 500 }, function(reply, err) ... end)   -- reply = { name, endpoints, host }
--   end)
--
-- Every call takes a callback cb(reply, err) that runs exactly once, from the loop: the reply table, or nil and
-- the reason (the daemon's error, a timeout, or the channel's close). A nil callback ignores the result.
-- Timeouts follow dca.clients (request_timeout, default clients.TIMEOUT). Exit events: { child =, pid =,
-- name =, host =, code = N } or { ..., signal = "SIGSEGV" }; given to the spawn's on_exit and to the handler
-- set with client:on_exit(fn). dca.clients.lookup(d, name, wait, cb) is the lookup production code uses.
local clients = require "dca.clients"

local tonumber, tostring, type, sformat = tonumber, tostring, type, string.format

local M = {}

local SIGNAMES = { [1] = "HUP", [2] = "INT", [3] = "QUIT", [4] = "ILL", [6] = "ABRT", [7] = "BUS", [8] = "FPE",
                   [9] = "KILL", [11] = "SEGV", [13] = "PIPE", [14] = "ALRM", [15] = "TERM" }
--- An exit event as words: "killed by SIGSEGV on host h1" | "exited with code 1 on host h1"; the reason a
--- process gave before it ended (`failed`, host/node.h) first: "parameter 'tau' must be positive, got -0.005
--- (exited with code 1 on host h1)".
function M.describe_exit(msg, host)
  if type(msg.reason) == "string" and msg.reason ~= "" then
    return sformat("%s (%s)", msg.reason, M.describe_exit({ signal = msg.signal, code = msg.code }, host))
  end
  if msg.signal then
    local s = tonumber(msg.signal) and SIGNAMES[tonumber(msg.signal)] or tostring(msg.signal)
    return sformat("killed by SIG%s on host %s", tostring(s):gsub("^SIG", ""), host)
  end
  return sformat("exited with code %s on host %s", tostring(msg.code), host)
end


local Client = clients.class({})
M.Client = Client

function Client:_event(msg)
  if msg.type == "exit" then
    local h = self.exit_handlers[msg.child]
    self.exit_handlers[msg.child] = nil
    if h then h(msg) end
    if self.exit_fn then self.exit_fn(msg) end
  elseif self.event_fn then
    self.event_fn(msg)
  end
end

--- Wraps an open channel to a daemon. opts.request_timeout: seconds per request.
function M.wrap(ch, opts)
  local self = clients.wrap(ch, Client, opts)
  self.exit_handlers = {}
  return self
end

--- Connects to the daemon at `addr`. `opts`: those of core.connect (key, key_file, timeout for the handshake)
--- plus `request_timeout`. Calls cb(client) or cb(nil, err).
function M.connect(addr, opts, cb)
  require("dca.core").connect(addr, opts or {}, function(ch, err)
    if not ch then cb(nil, err) return end
    local self = M.wrap(ch, opts)
    self.address = addr
    cb(self)
  end)
end

--- Starts argv on the daemon's host. opts: name (for reports), on_exit(ev), timeout (s), shared (join the
--- running child spawned shared under `name` instead of starting another; host/daemon.h), fence and kill_after
--- (seconds: the child is fenced when this channel is silent that long; host/fence.h).
function Client:spawn(argv, opts, cb)
  opts = opts or {}
  self:request({ type = "spawn", argv = argv, name = opts.name, shared = opts.shared, fence = opts.fence,
                 kill_after = opts.kill_after }, opts.timeout,
    function(reply, err, full)
      if reply and reply.child and opts.on_exit then self.exit_handlers[reply.child] = opts.on_exit end
      if cb then cb(reply, err, full) end
    end)
end

--- Sends `signal` ("SIGTERM" when nil, a name such as "SIGKILL", or a number) to a child's process group.
function Client:kill(child, signal, cb)
  self:request({ type = "kill", child = child, signal = signal }, nil, cb)
end

--- Looks `name` up here and at the daemon's peers. opts: wait_ms (wait that long for it to be registered),
--- timeout (s; default: the wait plus the client's request timeout).
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

return M
