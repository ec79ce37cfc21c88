-- dca.scenario.memory: the "memory" backend of dca.scenario: the supervisor tree in dca.supervisor.memory
-- (simulated time, exact), its nodes behaving as their type says (M.behave: the built-in test controllers).
-- Same methods as the real backend (see dca.scenario).
local fake = require "dca.supervisor.memory"

local M = {}

local ipairs, pairs, type, tostring, sformat, error = ipairs, pairs, type, tostring, string.format, error

-- The registry's manifests (dca.core.types(), once; none without a registry).
local manifests
local function types()
  if not manifests then
    local ok, core = pcall(require, "dca.core")
    manifests = ok and type(core) == "table" and core.types and core.types() or {}
  end
  return manifests
end

-- The value of a node's parameter `name`: its .dca argument at the manifest's position for the parameter, else
-- the manifest's default, else `default` (also when the type has no manifest, by position `at`). Numbers only
-- when `default` is a number.
local function param(n, name, at, default)
  local m, v = types()[n.type], nil
  for i, pm in ipairs(m and m.params or {}) do
    if pm.name == name then at, v = nil, n.args[i] if v == nil then v = pm.default end break end
  end
  if at then v = n.args[at] end
  if type(default) == "number" then return tonumber(v) or default end
  if v == nil then return default end
  return v
end

-- The name of a node's first output (from its manifest), else `default`.
local function out(n, default)
  local m = types()[n.type]
  local o = m and m.outputs and m.outputs[1]
  return o and o.name or default
end

-- Behaviours of the built-in test controllers (controllers/builtins) in the memory backend: only what the
-- in-memory cluster needs to play them (when they end, what they write); their parameters' names, positions
-- and defaults and their output ports come from the registry's manifests.
M.behave = {
  Timer = function(n) n:after(param(n, "seconds", 1, 1), function() n:done("timeout") end) end,
  Deadline = function(n)
    local s = param(n, "seconds", 1, 1)
    n:after(s, function() n:aborted("deadline of " .. tostring(n.args[1]) .. " s passed") end)
  end,
  Constant = function(n)
    local v, period, port = param(n, "values", 2, 0), param(n, "period", 1, 0), out(n, "Out")
    if period > 0 then n:every(period, function() n:write(port, v) end) else n:write(port, v) end
  end,
  Gain = function(n)
    local port = out(n, "Out")
    n.on_input = function(self, _, v) self:write(port, param(self, "k", 1, 1) * (tonumber(v) or 0)) end
  end,
  Sum = function(n)
    local port = out(n, "Out")
    n.on_input = function(self) self:write(port, (tonumber(self.ports.In1) or 0) + (tonumber(self.ports.In2) or 0)) end
  end,
  Threshold = function(n)
    local level, dir = param(n, "level", 1, 0), param(n, "direction", 2, "rising")
    local prev
    n.on_input = function(self, _, v)
      v = tonumber(v) or 0
      if prev then
        local up, down = prev < level and v >= level, prev > level and v <= level
        if ((dir == "rising" or dir == "either") and up) or ((dir == "falling" or dir == "either") and down) then
          self:done(v)
        end
      end
      prev = v
    end
  end,
  Counter = function(n)
    local limit, port = math.tointeger(param(n, "limit", 2, 0)) or 0, out(n, "Count")
    n:every(param(n, "period", 1, 1), function(k)
      n:write(port, k)
      if limit > 0 and k >= limit then n:done(k) end
    end)
  end,
  Crash = function(n)
    local ticks = param(n, "ticks", 1, 1)
    n:every(param(n, "period", 3, 0.001), function(k) if k >= ticks then n.c:kill(n.path, "SEGV") end end)
  end,
}

local System = {}
System.__index = System

--- A system of `spec` in memory, not started yet. opts: behave (behaviours by type over M.behave), timeouts,
--- heartbeat, config (a defaults file), set ({ key = value } over it).
function M.system(spec, opts)
  local behave = setmetatable(opts.behave or {}, { __index = M.behave })
  local repo = {}
  if opts.config then
    local entries, cerr = require("dca.config").read_file(opts.config)
    if not entries then error(cerr, 0) end
    for _, e in ipairs(entries) do repo[e.key] = e.value end
  end
  for k, v in pairs(opts.set or {}) do repo[k] = v end
  local c = fake.cluster{ behave = behave, timeouts = opts.timeouts, heartbeat = opts.heartbeat or { 1, 5 },
                          config = repo }
  local s = setmetatable({ spec = spec, c = c, file = opts.file, root = opts.root, backend = "memory" }, System)
  s.sup = c:root(spec, { timeouts = opts.timeouts })   -- (the root's console: Shared.repl)
  return s
end

--- Starts, connects and confirms the whole tree (raises with the reason when the start fails).
function System:up(timeout)
  local ok, err = self.c:configure(self.c.t + (timeout or 30))
  if not ok then error("start failed: " .. tostring(err), 0) end
  return true
end

--- Like up(), but returns nil, reason instead of raising.
function System:try_up(timeout)
  return self.c:configure(self.c.t + (timeout or 30))
end

--- Sends "run" to the root (its expression starts).
function System:run(init) self.c:start(init) self:settle(0) end

--- Lets the system run for `s` seconds of its time.
function System:settle(s) self.c:settle(self.c.t + (s or 0)) end

--- Waits until pred() is true (checked after every event), at most `timeout` seconds. Raises on timeout.
function System:wait(what, pred, timeout)
  local ok = self.c:settle(self.c.t + (timeout or 10), pred)
  if not ok then error(sformat("timed out after %gs waiting for %s", timeout or 10, what), 2) end
end

--- Waits for the root's outcome ({type = "done", value} | {type = "aborted", path, reason}).
function System:wait_outcome(timeout)
  self:wait("the root's outcome", function() return self.c.outcome ~= nil end, timeout)
  self.c:settle(self.c.t) -- the stops it caused are acknowledged
  return self.c.outcome
end

--- The state of a process ("running", "done", "inactive", "exited", "lost", ...) as its owner sees it.
function System:state(path)
  local owner = self.c.sups[path:match("^(.*)%.[^.]+$") or ""]
  local ch = owner and owner.children[path:match("[^.]+$")]
  local sup = self.c.sups[path]
  -- a group answers for itself unless its owner has lost it (as the real tree() does)
  if sup and not (ch and (ch.state == "lost" or ch.state == "gone" or ch.state == "exited")) then return sup.state end
  return ch and ch.state
end

function System:wait_state(path, state, timeout)
  self:wait(path .. " " .. state, function() return self:state(path) == state end, timeout)
end

--- Waits until pred(value of `path`.`port`) holds, at most `timeout` seconds. --> the value
function System:wait_read(path, port, pred, timeout)
  local v
  self:wait(path .. "." .. port, function() v = self:read(path, port) return pred(v) end, timeout)
  return v
end

--- Injects an event as the process at `path` ("done", value | "aborted", reason).
function System:inject(path, kind, value)
  local node = self.c:node(path)
  if node and node.running then
    if kind == "done" then node:done(value) else node:aborted(value or "injected") end
  else
    local msg = kind == "done" and { type = "done", value = value } or { type = "aborted", reason = value or "injected" }
    local r
    self.c.root_sup:inject(path, msg, function(ok, err) r = { ok, err } end)
    self.c:settle(self.c.t, function() return r ~= nil end)
    if not r or not r[1] then error("inject " .. path .. ": " .. tostring(r and r[2]), 2) end
  end
  self.c:settle(self.c.t)
end

--- Faults: kill a process with a signal, lose a whole host, drop the connections of a set.
function System:kill(path, sig)
  if not self.c:kill(path, sig or "KILL") then error("no live process " .. path, 2) end
  self.c:settle(self.c.t)
end
function System:lose_host(host) self.c:lose_host(host) self.c:settle(self.c.t) end
--- Stops a process (SIGSTOP): its sockets stay open, it answers nothing (the heartbeat finds it).
function System:freeze(path)
  if not self.c:freeze(path) then error("no live process " .. path, 2) end
end
--- Stops a whole host without closing anything (its daemon, SIGSTOP; here: every process on it).
function System:freeze_host(host)
  for _, p in ipairs(self.c.procs) do
    if p.host == host and p.alive then p.frozen = true end
  end
end
--- Whether the process at `path` is alive (frozen counts as alive).
function System:exists(path)
  for _, p in ipairs(self.c.procs) do if p.path == path and p.alive then return true end end
  return false
end
function System:drop(path, set)
  local node = self.c:node(path)
  if not node then error("no node " .. path, 2) end
  local kept = {}
  for _, k in ipairs(node.conns) do if k.set ~= set then kept[#kept + 1] = k end end
  node.conns = kept
  node.active[set] = nil
end

--- Reloads the system file (parse + check first): the old version keeps running on an error.
--- Returns the lines saying what changed, or nil and the error text (file:line:col).
function System:reload(file)
  local lines, err
  require("dca.reload").system(self.c.root_sup, file or self.file, { root = self.root },
    function(l, e) lines, err = l, e end)
  if err then return nil, err end
  self.c:settle(self.c.t, function() return lines ~= nil end)
  return lines or {}
end

--- The latest value of a port of a leaf.
function System:read(path, port)
  local node = self.c:node(path)
  if not node then error("no node " .. path, 2) end
  return node.ports[port]
end

--- A node's view: running flag, active sets, connections, commands it received.
function System:node(path) return self.c:node(path) end

--- The transition lines of every supervisor so far ("main.motion.puma: aborting", ...).
function System:transitions() return self.c.lines end

--- Processes still alive (besides the root).
function System:alive() return self.c:alive() end


function System:now() return self.c.t end

--- The configuration repository as a host sees it (memory backend: one content shared by every host, a write
--- seen at once everywhere): get(key), set(key, value) or set{ key = value }, list(prefix), watch(prefix)
--- --> a list the changes below prefix are appended to ({ key, value, origin }). Errors raise.
function System:config(host)
  local c = self.c
  c.config = c.config or {}
  c.config_watchers = c.config_watchers or {}
  local repo = {}
  function repo.get(_, key)
    local v = c.config[key]
    if v == nil then error(sformat("unknown key '%s' on host %s", tostring(key), tostring(host)), 2) end
    return v
  end
  function repo.set(_, key, value)
    local values = type(key) == "table" and key or { [key] = value }
    for k, v in pairs(values) do
      for _, w in ipairs(c.config_watchers) do
        if k == w.prefix or w.prefix == "" or k:sub(1, #w.prefix + 1) == w.prefix .. "." then
          w.events[#w.events + 1] = { key = k, value = v, origin = host }
        end
      end
    end
    c:config_set(values)  -- and the supervisors' watches (their leaves' live parameters)
    return true
  end
  function repo.list(_, prefix)
    local out = {}
    for k, v in pairs(c.config) do
      if not prefix or prefix == "" or k == prefix or k:sub(1, #prefix + 1) == prefix .. "." then
        out[#out + 1] = { key = k, value = v }
      end
    end
    table.sort(out, function(a, b) return a.key < b.key end)
    return out
  end
  function repo.watch(_, prefix)
    local w = { prefix = prefix or "", events = {} }
    c.config_watchers[#c.config_watchers + 1] = w
    return w.events
  end
  return repo
end

--- Stops the whole tree (LIFO) and checks nothing is left.
function System:stop()
  local done = false
  self.c.root_sup:shutdown(function() done = true end)
  self.c:settle(self.c.t + 60, function() return done end)
  self.stopped = true
  return #self.c:alive() == 0
end

return M
