-- dca.clients.console: the client of a supervisor's console (`dca repl`; the server side is
-- dca.supervisor.console): evaluate a line, complete a prefix, follow the supervisor's transition lines.
--
--   local console = require "dca.clients.console"
--   console.find(DAEMON_ADDR, "main.door", { key_file = KEY }, function(addr, err) end)  -- by path, at a daemon
--   console.connect(addr, { key_file = KEY }, function(c, err)
--     c:eval("tree()", function(reply, err) end)       -- reply = { output =, more = (the chunk is incomplete) }
--     c:complete("sta", function(reply, err) end)      -- reply = { candidates = { ... } }
--     c:follow(function(line) end)                     -- each transition line, from now on
--   end)
local clients = require "dca.clients"

local M = {}

local tostring = tostring

-- Seconds a line may take to evaluate (it may wait for other supervisors), and a completion (asked while a
-- person types).
M.EVAL_TIMEOUT, M.COMPLETE_TIMEOUT = 60, 2

local Client = clients.class({})
M.Client = Client

function Client:_event(msg)
  if msg.type == "log" and msg.line and self.follow_fn then self.follow_fn(msg.line) end
end

--- Evaluates `line` in the supervisor. cb(reply { output, more }) | cb(nil, err)
function Client:eval(line, cb) self:request({ type = "repl", line = line }, M.EVAL_TIMEOUT, cb) end
--- The completions of `prefix`. cb(reply { candidates }) | cb(nil, err)
function Client:complete(prefix, cb) self:request({ type = "complete", prefix = prefix }, M.COMPLETE_TIMEOUT, cb) end
--- fn(line) for each transition line of the supervisor from now on.
function Client:follow(fn, cb)
  self.follow_fn = fn
  self:request({ type = "follow" }, nil, cb)
end

--- Connects to a supervisor's console endpoint `addr`. cb(client) | cb(nil, err)
function M.connect(addr, opts, cb) clients.connect(addr, opts, Client, cb) end

--- The console address of the supervisor registered as `path`, asked of the daemon at `daemon` (waiting 2 s
--- for it to register). cb(addr) | cb(nil, err)
function M.find(daemon, path, opts, cb)
  require("dca.clients.daemon").connect(daemon, opts, function(d, err)
    if not d then cb(nil, "daemon " .. daemon .. ": " .. tostring(err)) return end
    clients.lookup(d, path, 2, function(ep, lerr)
      d:close()
      if not ep or not ep.control then cb(nil, "no supervisor '" .. path .. "': " .. tostring(lerr)) return end
      cb(ep.control)
    end)
  end)
end

return M
