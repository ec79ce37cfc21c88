-- dca.clients.node: drives a `dca node` over its control channel (dca.core), as a supervisor does.
--
--   local node = require "dca.clients.node"
--   node.connect(endpoints.control, { key_file = KEY }, function(n, err)
--     if not n then error(err) end
--     n:on_done(function(value, msg) ... end)          -- DONE(value) of the node's controller
--     n:on_aborted(function(reason, msg) ... end)      -- ABORTED(reason)
--     n:on_event(function(msg) ... end)                -- other events: broken {port, peer, set, reason}, overflow
--     n:connect({ out = "Out", to = "/sys/b", ["in"] = "In", set = "g:x[l]", mode = "push", queue = 16 },
--       function(reply, err) ... end)                  -- reply.transport: "inprocess" | "unix" | "tcp"
--     n:activate("g:x[l]", cb)  n:init(cb)  n:run(init_value, cb)  n:stop(cb)  n:deactivate(set, cb)
--     n:read("Out", cb)                                -- reply = { value =, count = }
--   end)
--
-- Every call takes a callback cb(reply, err) that runs exactly once, from the loop: the reply table, or nil and
-- the reason (the node's error, a timeout, or the channel's close). A nil callback ignores the result. The
-- requests and replies are those of host/node.h; timeouts follow dca.clients.
local clients = require "dca.clients"

local M = {}

local Client = clients.class({})
M.Client = Client

function Client:_event(msg)
  if msg.type == "done" then
    if self.done_fn then self.done_fn(msg.value, msg) end
  elseif msg.type == "aborted" then
    if self.aborted_fn then self.aborted_fn(msg.reason, msg) end
  elseif self.event_fn then
    self.event_fn(msg)
  end
end

--- Wraps an open control channel `ch` (from core.connect). `opts.request_timeout`: seconds per request.
function M.wrap(ch, opts) return clients.wrap(ch, Client, opts) end

--- Connects to a node's `control` address. `opts`: those of core.connect (key, key_file, timeout for the
--- handshake) plus `request_timeout`. Calls cb(client) or cb(nil, err).
function M.connect(addr, opts, cb) clients.connect(addr, opts, Client, cb) end

--- Acquires and resets the controller.
function Client:init(cb) self:request({ type = "init" }, nil, cb) end
--- Starts a run with an initial value (nil outside value bindings).
function Client:run(init, cb) self:request({ type = "run", init = init }, nil, cb) end
--- Stops the run (actuators safe); a later DONE/ABORTED of that run is ignored by the node.
function Client:stop(cb) self:request({ type = "stop" }, nil, cb) end

--- Connects one of the node's outputs to `spec.to`'s input: spec = {out, to, in, set, mode, queue}.
function Client:connect(spec, cb)
  self:request({ type = "connect", out = spec.out, to = spec.to, ["in"] = spec["in"], set = spec.set,
                 mode = spec.mode, queue = spec.queue }, spec.timeout, cb)
end
--- Removes every connection of a set from this node's outputs.
function Client:disconnect(set, cb) self:request({ type = "disconnect", set = set }, nil, cb) end
--- Activates a connection set (a flag flip at the source).
function Client:activate(set, cb) self:request({ type = "activate", set = set }, nil, cb) end
--- Deactivates a connection set.
function Client:deactivate(set, cb) self:request({ type = "deactivate", set = set }, nil, cb) end

--- The latest sample of any port: reply = { value =, count = }.
function Client:read(port, cb) self:request({ type = "read", port = port }, nil, cb) end
--- Asks an input's pull connections for their latest sample; the reply comes when it has arrived.
function Client:pull(port, timeout, cb)
  timeout = timeout or self.timeout
  self:request({ type = "pull", port = port, timeout_ms = math.floor(timeout * 1000) }, timeout + self.timeout, cb)
end
--- Ports with counters, and connections: reply = { inputs =, outputs =, links =, accepted =, bytes_received = }.
function Client:ports(cb) self:request({ type = "ports" }, nil, cb) end
--- Timer lateness statistics: reply = { timers = { {name, count, missed, p50_us, p99_us, max_us} ... }, clock = }.
function Client:stats(cb) self:request({ type = "stats" }, nil, cb) end
--- Simulated clock only: runs every timer due at or before `t_ns`; reply = { now =, next = }.
function Client:advance(t_ns, cb) self:request({ type = "advance", t = t_ns }, nil, cb) end
--- Asks the node to exit (0).
function Client:exit(cb) self:request({ type = "exit" }, nil, cb) end

--- Handlers for the node's events.
function Client:on_done(fn) self.done_fn = fn end
function Client:on_aborted(fn) self.aborted_fn = fn end
function Client:on_event(fn) self.event_fn = fn end

return M
