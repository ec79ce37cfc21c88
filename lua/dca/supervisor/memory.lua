-- dca.supervisor.memory: an in-memory cluster for the supervisor's logic (no sockets, no clock).
--
-- Every message between processes goes through one FIFO queue and is deep-copied (it must survive
-- serialisation); time is virtual and only advances when the queue is empty. Leaves are fake nodes whose
-- behaviour a test scripts; groups are real dca.supervisor objects on fake runtimes, so a whole tree runs
-- exactly as it would across daemons, only in one Lua state and deterministically.
--
--   local fake = require "dca.supervisor.memory"
--   local c = fake.cluster{ behave = { Timer = function(node, init) node:after(1, function() node:done("timeout") end) end } }
--   local root = c:root(spec)           -- the root DCAS (its parent is the test: c.outcome, c.reports)
--   c:configure()  --> true | nil, reason   (runs the start protocol to the end)
--   c:start(init)                           -- "run" to the root
--   c:settle(max_t)                         -- processes events (and virtual time up to max_t)
--   c:node(path):done(v) / :aborted(reason) -- a leaf's events
--   c:kill(path, "SEGV") ; c:lose_host("h3") ; c:fail_spawn[path] = "reason" | "silent" ; c:freeze(path)
--   c.spawn_delay[path] = seconds            -- that process starts only after this much virtual time
--   c.refuse_to[name] = "reason"             -- a `connect` to that destination is refused (a tap point gone)
--   c.code[path] = manifest                  -- the ports its node lists from then on (`ports {}`): new code
--   fake.cluster{ heartbeat = { period, silence } }  -- supervisors ping their child supervisors
--   fake.cluster{ types = { T = manifest }, world = true }  -- device ports, wired to the fake `world` node
--   fake.cluster{ config = { ["door.stop_distance"] = 0.45 } } -- the repository config("key") arguments read;
--                                            with it each supervisor has rt.config_client (get, set, watch, unwatch)
--   c:config_set{ key = value }              -- a write to it, as from another host: every watch sees it
--   c.refuse_param[path] = "reason"          -- that leaf refuses `set_param` (a live parameter) with the reason
--   c.trace      -- every delivered message: { from =, to =, type = , kind = "request"|"reply"|"event" }
--   c.commands   -- every command a node received: "path type [set]"
local supervisor = require "dca.supervisor"
local spec_mod = require "dca.supervisor.spec"

local M = {}

local pairs, ipairs, type, tostring, error, sformat = pairs, ipairs, type, tostring, error, string.format
local remove = table.remove

local function copy(v, depth)
  depth = depth or 0
  if depth > 64 then error("message too deep (a cycle?)") end
  local t = type(v)
  if t == "table" then
    local r = {}
    for k, x in pairs(v) do
      if type(k) ~= "string" and type(k) ~= "number" then error("message key of type " .. type(k)) end
      r[k] = copy(x, depth + 1)
    end
    return r
  elseif t == "function" or t == "userdata" or t == "thread" then
    error("message holds a " .. t)
  end
  return v
end
M.copy = copy

local Cluster = {}
Cluster.__index = Cluster

local Node = {}
Node.__index = Node

function M.cluster(opts)
  opts = opts or {}
  local c = setmetatable({
    t = 0, queue = {}, qhead = 1, qtail = 0, timers = {}, tseq = 0,
    behave = opts.behave or {}, nodes = {}, sups = {}, procs = {},
    trace = {}, commands = {}, reports = {}, fail_spawn = {}, spawn_delay = {}, lost_hosts = {}, refuse_param = {},
    outcome = nil, timeouts = opts.timeouts, lines = {}, pid = 100, heartbeat = opts.heartbeat,
    types = opts.types, config = opts.config, code = {},
  }, Cluster)
  if opts.world then c:add_world(opts.world_host) end
  return c
end

function Cluster:push(fn)
  self.qtail = self.qtail + 1
  self.queue[self.qtail] = fn
end

function Cluster:after(s, fn)
  self.tseq = self.tseq + 1
  local tm = { at = self.t + s, seq = self.tseq, fn = fn }
  self.timers[#self.timers + 1] = tm
  return { cancel = function() tm.cancelled = true end }
end

--- Processes queued work; when idle, advances virtual time to the next timer (not beyond max_t).
function Cluster:settle(max_t, pred)
  max_t = max_t or (self.t + 3600)
  local steps = 0
  while true do
    if pred and pred() then return true end
    if self.qhead <= self.qtail then
      local fn = self.queue[self.qhead]
      self.queue[self.qhead] = nil
      self.qhead = self.qhead + 1
      steps = steps + 1
      if steps > 1e6 then error("fake cluster: no quiescence after 1e6 steps") end
      fn()
    else
      self.queue, self.qhead, self.qtail = {}, 1, 0
      local best, bi
      local live = {}
      for _, tm in ipairs(self.timers) do
        if not tm.cancelled then
          live[#live + 1] = tm
          if not best or tm.at < best.at or (tm.at == best.at and tm.seq < best.seq) then best, bi = tm, #live end
        end
      end
      self.timers = live
      if not best or best.at > max_t then
        if not pred then self.t = math.max(self.t, math.min(max_t, self.t)) end
        return pred and pred() or false
      end
      remove(self.timers, bi)
      self.t = best.at
      best.fn()
    end
  end
end

function Cluster:note(from, to, msg, kind)
  self.trace[#self.trace + 1] = { from = from, to = to, type = msg.type, kind = kind, leaf = msg.leaf }
end

-- A process slot: alive flag, host, and the function that delivers a message to it.
function Cluster:_proc(path, host, kind)
  self.pid = self.pid + 1
  local p = { path = path, host = host, kind = kind, alive = true, pid = self.pid }
  self.procs[#self.procs + 1] = p
  return p
end

-- A handle from `owner` (a path) to the process `p` whose requests are served by serve(msg, reply).
function Cluster:_handle(owner, p, serve)
  local c = self
  local h = {}
  function h.request(msg, timeout, cb)
    msg = copy(msg)
    local answered = false
    local tm = c:after(timeout or 5, function()
      if not answered then answered = true cb(nil, "timeout after " .. tostring(timeout) .. "s") end
    end)
    c:push(function()
      if p.frozen and p.alive then return end -- stopped (SIGSTOP): no answer, the request times out
      if not p.alive then
        -- a dead process's channel is closed: the request fails at once, as over a socket
        if not answered then answered = true tm.cancel() cb(nil, "channel closed: " .. p.path .. " is gone") end
        return
      end
      c:note(owner, p.path, msg, "request")
      serve(msg, function(r)
        r = copy(r)
        c:push(function()
          if answered then return end
          answered = true
          tm.cancel()
          c:note(p.path, owner, r, "reply")
          cb(r)
        end)
      end)
    end)
  end
  function h.send(msg)
    -- an event (no answer expected): a node or supervisor serves requests only, as over a real channel
    msg = copy(msg)
    c:push(function()
      if not (p.alive and not p.frozen) then return end
      c:note(owner, p.path, msg, "send")
    end)
  end
  function h.kill(sig, cb)
    c:_die(p, "killed by SIG" .. tostring(sig), true)
    if cb then c:push(function() cb(true) end) end
  end
  function h.lost() p.on_exit = nil end
  return h
end

-- `lost`: its host was lost, not a crash of its own (the owner's policy tells them apart by it, not by the text).
function Cluster:_die(p, reason, quiet, lost)
  if not p.alive then return end
  p.alive = false
  if p.kind == "group" then
    local s = self.sups[p.path]
    if s then
      -- its own children die with it only when their host goes too; a supervisor's death leaves them to
      -- the daemon, which stops what the dead supervisor started (its channels closed)
      for _, ch in pairs(s.children) do
        if ch.handle and ch.handle.kill then ch.handle.kill("TERM") end
      end
    end
  end
  if not quiet and p.on_exit then
    local f = p.on_exit
    self:push(function() f(reason, lost) end)
  end
end

--- A fake robot process registered as `world` (a node whose ports are the robot's signals): c:node("world").
function Cluster:add_world(host)
  local p = self:_proc("world", host or "robot", "leaf")
  local node = setmetatable({ c = self, p = p, path = "world", type = "World", host = p.host, args = {},
    owner = nil, name = "world", conns = {}, active = {}, running = true, runs = 0, ports = {} }, Node)
  self.nodes.world = node
  self.world_proc = p
  self.world_handle = self:_handle("world-client", p, function(msg, reply) node:serve(msg, reply) end)
  return node
end

--- The fake node of a leaf path.
function Cluster:node(path) return self.nodes[path] end

function Cluster:_spawn(owner_sup, child, cb)
  local c = self
  local mode = c.fail_spawn[child.path]
  if c.lost_hosts[child.host] then mode = "host " .. child.host .. " unreachable" end
  if mode == "silent" then return end
  local delay = c.spawn_delay[child.path]
  if delay and not child.delayed then
    c:after(delay, function() c:_spawn(owner_sup, setmetatable({ delayed = true }, { __index = child }), cb) end)
    return
  end
  if mode then c:push(function() cb(nil, mode) end) return end
  if not child.resolved then
    -- config("key") arguments: read from the cluster's repository (opts.config, one content for every host)
    local repo = c.config or {}
    local client = { get = function(_, key, k)
      c:push(function()
        if repo[key] == nil then k(nil, sformat("unknown key '%s' on host %s", key, tostring(child.host)))
        else k(copy(repo[key])) end
      end)
    end }
    spec_mod.resolve_leaf(child, client, function(resolved, err)
      if not resolved then cb(nil, err) return end
      c:_spawn(owner_sup, setmetatable({ resolved = true }, { __index = resolved }), cb)
    end)
    return
  end
  local p = c:_proc(child.path, child.host, child.kind)
  p.on_exit = function(reason, lost) owner_sup:child_exit(child.name, reason, lost) end
  if child.kind == "leaf" then
    local node = setmetatable({ c = c, p = p, path = child.path, type = child.type, host = child.host,
      args = child.args, owner = owner_sup, name = child.name, conns = {}, active = {}, running = false,
      runs = 0, ports = {} }, Node)
    c.nodes[child.path] = node
    local h = c:_handle(owner_sup.path, p, function(msg, reply) node:serve(msg, reply) end)
    c:push(function() cb(h) end)
  else
    local holder = {}
    local h = c:_handle(owner_sup.path, p, function(msg, reply)
      local s = holder.sup
      if not s then
        if msg.type ~= "configure" then reply({ type = "error", reason = "not configured" }) return end
        s = supervisor.new(msg.spec, c:rt(p, function(m)
          if (p.alive and not p.frozen) then
            local cm = copy(m)
            c:push(function()
              c:note(p.path, owner_sup.path, cm, "event")
              owner_sup:child_message(child.name, cm)
            end)
          end
        end), { progress = msg.progress, timeouts = c.timeouts })
        holder.sup = s
        c.sups[child.path] = s
      end
      s:handle(msg, reply)
    end)
    c:push(function() cb(h) end)
  end
end

--- A runtime for a supervisor living in process `p`; report(msg) goes to its parent.
function Cluster:rt(p, report)
  local c = self
  local rt = {}
  rt.spawn = function(child, cb) c:_spawn(rt.sup_of(), child, cb) end
  rt.defer = function(fn) c:push(function() if (p.alive and not p.frozen) then fn() end end) end
  rt.after = function(s, fn)
    local tm = c:after(s, function() if (p.alive and not p.frozen) then fn() end end)
    return { cancel = tm.cancel }
  end
  rt.report = report
  rt.log = function(line) c.lines[#c.lines + 1] = line end
  rt.now = function() return c.t end
  rt.sup_of = function() return c.sups[p.path] end
  rt.types = function() return c.types or {} end
  if c.config then rt.config_client = function(cb) c:push(function() cb(c:_config_client(p)) end) end end
  rt.world = function(msg, timeout, cb)
    local w = c.world_handle
    if not w then c:push(function() cb(nil, "no process is registered as `world`", true) end) return end
    w.request(msg, timeout, cb)
  end
  if c.heartbeat then
    -- child supervisors are pinged as by the real runtime (cluster{heartbeat = {period, silence}})
    rt.heartbeat = function() return c.heartbeat[1], c.heartbeat[2] end
    rt.every = function(s, fn)
      local t = { on = true }
      local function tick()
        if not t.on or not (p.alive and not p.frozen) then return end
        fn()
        if t.on then c:after(s, tick) end
      end
      c:after(s, tick)
      return { cancel = function() t.on = false end }
    end
  end
  return rt
end

local function under(key, prefix)
  return prefix == "" or key == prefix or key:sub(1, #prefix + 1) == prefix .. "."
end

--- A write to the repository (cluster{config}), as from any host: each watch whose process lives sees it.
function Cluster:config_set(values)
  self.config = self.config or {}
  local keys = {}
  for k in pairs(values) do keys[#keys + 1] = k end
  table.sort(keys)
  for _, key in ipairs(keys) do
    self.config[key] = copy(values[key])
    for _, w in ipairs(self.config_watches or {}) do
      if under(key, w.prefix) then
        local ev = { key = key, value = copy(values[key]), origin = "memory" }
        self:push(function() if w.p.alive and not w.p.frozen then w.fn(ev) end end)
      end
    end
  end
end

-- The repository as process `p` reaches it (rt.config_client): dca.clients.config's get, set, watch, unwatch.
function Cluster:_config_client(p)
  local c = self
  c.config_watches = c.config_watches or {}
  local function later(k, ...)
    local r = table.pack(...)
    if k then c:push(function() k(table.unpack(r, 1, r.n)) end) end
  end
  local client = { host = "memory" }
  function client.get(_, key, k)
    if c.config[key] == nil then later(k, nil, sformat("unknown key '%s'", tostring(key))) else later(k, copy(c.config[key])) end
  end
  function client.set(_, values, k)
    c:config_set(values)
    later(k, { keys = 1, seq = 1, origin = "memory" })
  end
  function client.watch(_, prefix, fn, k, owner)
    c.config_watches[#c.config_watches + 1] = { p = p, prefix = prefix or "", fn = fn, owner = owner }
    later(k, { prefix = prefix })
  end
  function client.unwatch(_, prefix, k, owner)
    for i = #c.config_watches, 1, -1 do
      local w = c.config_watches[i]
      if w.p == p and w.prefix == (prefix or "") and w.owner == owner then remove(c.config_watches, i) end
    end
    later(k, { prefix = prefix })
  end
  return client
end

--- The root DCAS for `spec`; its reports land in c.reports and c.outcome.
function Cluster:root(spec, opts)
  -- the root lives in the test's own process (as in `dca run`): no host loss takes it down
  local p = self:_proc(spec.path, nil, "group")
  self.root_proc = p
  local s = supervisor.new(spec, self:rt(p, function(m)
    m = copy(m)
    self.reports[#self.reports + 1] = m
    if m.type == "done" or m.type == "aborted" then self.outcome = m end
  end), opts or { timeouts = self.timeouts })
  self.sups[spec.path] = s
  self.root_sup = s
  return s
end

--- Runs the root's start protocol to the end. --> true | nil, reason
function Cluster:configure(max_t)
  local res
  self.root_sup:configure(function(ok, err)
    if ok then res = { true } else
      self.root_sup:shutdown(function() res = { nil, err } end)
    end
  end)
  self:settle(max_t, function() return res ~= nil end)
  if not res then return nil, "configure did not finish" end
  return res[1], res[2]
end

function Cluster:start(init)
  self.outcome = nil
  self.root_sup:run_expr(init)
end

--- Settles until the root reported its outcome (or max_t). --> the outcome or nil
function Cluster:outcome_within(max_t)
  self:settle(max_t, function() return self.outcome ~= nil end)
  return self.outcome
end

--- Kills a leaf's or a supervisor's process with a signal (the Executer reports it to its owner).
function Cluster:kill(path, sig)
  for _, p in ipairs(self.procs) do
    if p.path == path and p.alive then
      local host = p.host
      self:_die(p, sformat("killed by SIG%s on host %s", sig or "KILL", tostring(host)))
      return true
    end
  end
  return false
end

--- Every process on `host` is gone; owners elsewhere hear "host lost".
function Cluster:lose_host(host)
  self.lost_hosts[host] = true
  for _, p in ipairs(self.procs) do
    if p.host == host and p.alive then self:_die(p, sformat("host %s lost (daemon gone)", host), false, true) end
  end
end

--- Stops a process (SIGSTOP): it keeps its channels open but answers nothing, sends nothing, runs no timer.
function Cluster:freeze(path)
  for _, p in ipairs(self.procs) do
    if p.path == path and p.alive then p.frozen = true return true end
  end
  return false
end

--- Processes still alive (the test's /proc).
function Cluster:alive()
  local list = {}
  for _, p in ipairs(self.procs) do
    if p.alive and p ~= self.root_proc and p ~= self.world_proc then list[#list + 1] = p.path end
  end
  return list
end

---------------------------------------------------------------------------------------------- fake nodes

function Node:serve(msg, reply)
  local t = msg.type
  local c = self.c
  c.commands[#c.commands + 1] = self.path .. " " .. t .. (msg.set and (" " .. msg.set) or "")
  if t == "init" then
    reply({ type = "ok" })
  elseif t == "run" then
    self.running = true
    self.runs = self.runs + 1
    self.run_id = self.runs
    reply({ type = "ok" })
    local b = c.behave[self.type]
    if b then b(self, msg.init) end
  elseif t == "stop" then
    self.running = false
    reply({ type = "ok" })
  elseif t == "connect" then
    if c.refuse_to and c.refuse_to[msg.to] then reply({ type = "error", reason = c.refuse_to[msg.to] }) return end
    -- the same connection again is the one already made (its destination is found by path at each write, so
    -- it reaches a restarted destination's new node, as host/endpoint replaces a link to a moved process)
    for _, k in ipairs(self.conns) do
      if k.out == msg.out and k.to == msg.to and k["in"] == msg["in"] and k.set == msg.set then
        reply({ type = "ok" })
        return
      end
    end
    self.conns[#self.conns + 1] = { out = msg.out, to = msg.to, ["in"] = msg["in"], set = msg.set, queue = msg.queue }
    reply({ type = "ok" })
  elseif t == "activate" then
    self.active[msg.set] = true
    reply({ type = "ok" })
  elseif t == "deactivate" then
    self.active[msg.set] = nil
    reply({ type = "ok" })
  elseif t == "ports" then
    -- its type's ports: the code a test put in place for its path (c.code), else its manifest (c.types); none
    -- listed when neither is known (the restart's check of them then has nothing to compare)
    local m = (c.code and c.code[self.path]) or (c.types and c.types[self.type])
    reply(m and { type = "ok", inputs = m.inputs or {}, outputs = m.outputs or {} } or { type = "ok" })
  elseif t == "read" then
    reply({ type = "ok", value = self.ports[msg.port] })
  elseif t == "set_param" then
    -- a live parameter: taken (node.params), or refused as the test asked (c.refuse_param)
    if c.refuse_param[self.path] then reply({ type = "error", reason = c.refuse_param[self.path] }) return end
    self.params = self.params or {}
    self.params[msg.name] = msg.value
    reply({ type = "ok", value = tostring(msg.value) })
  else
    reply({ type = "error", reason = "unknown command " .. tostring(t) })
  end
end

local function event(self, msg)
  if not (self.p.alive and not self.p.frozen) then return end
  local c, owner, name = self.c, self.owner, self.name
  msg = copy(msg)
  c:push(function()
    c:note(self.path, owner.path, msg, "event")
    owner:child_message(name, msg)
  end)
end

-- The node's run ends with event `msg` (only while it runs, like a controller). --> whether it did
local function finish_run(self, msg)
  if not self.running then return false end
  self.running = false
  event(self, msg)
  return true
end

--- The node ends its run DONE(value) or ABORTED(reason).
function Node:done(v) return finish_run(self, { type = "done", value = v }) end
function Node:aborted(reason) return finish_run(self, { type = "aborted", reason = reason }) end

--- Writes `v` on output `port`: delivered to the input of every destination whose set is active here.
function Node:write(port, v)
  self.ports[port] = v
  for _, k in ipairs(self.conns) do
    if k.out == port and self.active[k.set] then
      local dst = self.c.nodes[k.to]
      if dst and (dst.p.alive and not dst.p.frozen) then
        local vv = copy(v)
        self.c:push(function() dst:input(k["in"], vv) end)
      end
    end
  end
end

--- A sample arrives on input `port` (its behaviour's on_input runs while the node runs).
function Node:input(port, v)
  self.ports[port] = v
  if self.running and self.on_input then self.on_input(self, port, v) end
end

--- A periodic timer for the current run: fn(tick_number) every `period` until the run ends.
function Node:every(period, fn)
  local id, k = self.run_id, 0
  local function tick()
    if not (self.running and self.run_id == id and (self.p.alive and not self.p.frozen)) then return end
    k = k + 1
    fn(k)
    if self.running and self.run_id == id then self.c:after(period, tick) end
  end
  self.c:after(period, tick)
end

--- A timer on this node that fires only if the same run is still going.
function Node:after(s, fn)
  local id = self.run_id
  return self.c:after(s, function() if self.running and self.run_id == id and (self.p.alive and not self.p.frozen) then fn() end end)
end

---------------------------------------------------------------------------------------------- spec builders

--- Spec builders for tests: leaf(name, type, host, args), group(name, type, host, expr, children, sets, xio),
--- root(name, host, expr, children, sets) gives a finished spec with full paths, set(inst, label, {{a,o,b,i}}).
function M.leaf(name, typ, host, args) return { name = name, kind = "leaf", type = typ, host = host, args = args or {} } end
function M.group(name, typ, host, expr, children, sets, xio)
  return { name = name, kind = "group", type = typ, host = host,
           spec = { type = typ, host = host, expr = expr, children = children, sets = sets or {},
                    external_io = xio or {}, file = "test.dca", expr_line = 1, expr_col = 1 } }
end
local function finish(g, path)
  local s = g.spec
  s.path = path
  g.path = path
  for _, c in ipairs(s.children) do
    c.path = path .. "." .. c.name
    if c.kind == "group" then finish(c, c.path) end
  end
  return s
end
function M.root(name, host, expr, children, sets) return finish(M.group(name, name, host, expr, children, sets), name) end
function M.set(instance, label, conns)
  local list = {}
  for _, k in ipairs(conns) do list[#list + 1] = { from = k[1], out = k[2], to = k[3], ["in"] = k[4] } end
  return { instance = instance, label = label, connections = list }
end

return M
