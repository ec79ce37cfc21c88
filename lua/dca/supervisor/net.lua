-- dca.supervisor.net: the real runtime of a supervisor, over `dca.core` channels and the hosts' daemons.
--
-- argv[1] is "dca": the daemon starts its own executable (its allow-list admits `dca node|supervise|sim`).
-- Leaves start as `dca node --type T --name PATH --daemon ADDR -- ARGS` and sub-groups as
-- `dca supervise --name PATH --daemon ADDR`, each by the daemon (Executer) of its host; the supervisor then
-- looks the new process up by its path (NameServer) and opens a channel to its `control` endpoint.
-- Exit events from a daemon and closed channels become child_exit(name, reason, lost) on the owning supervisor
-- (lost: its host or channel was lost).
-- Placement (opts.placement, `dca run --placement`): "process" (default) starts each leaf as its own process;
-- "group" places the leaves of this group on one host in one shared node (`dca node --shared`), "host" every
-- leaf of the run on one host, whichever group it belongs to, in one shared node (host/node.h). A shared node
-- is spawned through the daemon's shared spawn (the first asker starts it, the others join; host/daemon.h);
-- its leaves are added with `add` and each is then reached at its own control address as any node. Its crash
-- ends each of its leaves with the signal (one child_exit per leaf); a leaf's kill removes that leaf only.
--
--   local rt = require("dca.supervisor.net").new{ hosts = { h1 = "127.0.0.1:7001" }, key = FILE, exe = DCA,
--                                                report = function(msg) end, log = function(line) end }
--   rt.bind(sup)           -- the supervisor whose children this runtime starts (after supervisor.new)
--   net.reply(ch, req, msg) -- answers a request that arrived on a channel
-- The runtime's methods are called with a dot (rt.spawn(child, cb)), as dca.supervisor calls them; inside,
-- they reach each other the same way (self.daemon(host, cb)). Daemons are reached with dca.clients.daemon,
-- started processes looked up and connected with dca.clients.open.
local core, config = require "dca.core", require "dca.config"
local clients, daemon_client = require "dca.clients", require "dca.clients.daemon"
local spec_mod = require "dca.supervisor.spec"

local M = {}

local ipairs, pairs, type, tostring, sformat, tonumber = ipairs, pairs, type, tostring, string.format, tonumber
local concat = table.concat

--- Answers the request number `id` (received on channel `ch`) with `msg`: {type = "ok", ...} or
--- {type = "error", reason = "..."}.
function M.reply(ch, id, msg)
  if not id or id == 0 then return false end
  if msg.type == "error" then return ch:reply_error(id, tostring(msg.reason)) end
  local payload = {}
  for k, v in pairs(msg) do if k ~= "type" then payload[k] = v end end
  return ch:reply(id, payload)
end

--- The requests a console (`dca repl`) may send to a supervisor.
M.CONSOLE = { repl = true, complete = true, tree = true, inject = true, restart = true, switch = true,
              stats = true, ping = true, ports = true, tap = true, config_set = true, estop = true, release = true,
              clock = true, add_child = true, remove_child = true, upgrade = true }

--- Answers one request `msg` (number `id`) of a console channel `ch` on supervisor `sup` (nil: not configured
--- yet). `follow {}` subscribes the channel to the transition lines in `followers` (a set of channels).
function M.console(ch, id, msg, sup, followers)
  if (id or 0) == 0 then return end
  if msg.type == "follow" then
    followers[ch] = true
    return M.reply(ch, id, { type = "ok" })
  end
  if not M.CONSOLE[msg.type] then
    return M.reply(ch, id, { type = "error", reason = "a console may send " ..
      "repl, complete, tree, inject, restart, switch, stats, ping, ports, tap, config_set, estop, release, " ..
      "clock, add_child, remove_child, upgrade or follow, not '" .. tostring(msg.type) .. "'" })
  end
  if not sup then return M.reply(ch, id, { type = "error", reason = "the supervisor is not configured yet" }) end
  sup:handle(msg, function(r) M.reply(ch, id, r) end)
end

--- Sends a transition line to every following console (closed ones are dropped). --> how many got it
function M.to_followers(followers, line)
  local n = 0
  for ch in pairs(followers) do
    if ch:is_open() then ch:send({ type = "log", line = line }) n = n + 1 else followers[ch] = nil end
  end
  return n
end

-- An argument as the node reads it: a number in the fewest digits that give it back exactly (-0.005, not
-- -0.0050000000000000001: the node's messages quote it).
local function argstr(v)
  if type(v) == "number" then
    if math.type(v) == "integer" then return tostring(v) end
    for _, f in ipairs({ "%.15g", "%.16g" }) do
      local s = sformat(f, v)
      if tonumber(s) == v then return s end
    end
    return sformat("%.17g", v)
  end
  return tostring(v)
end
M.argstr = argstr

-- Appends a node's real-time options for `rt` ({priority, cpu} of an rt { } section, or nil) to argv: on the wall
-- clock; a node on simulated time ignores them (docs/time.md, "Real time").
local function rt_argv(argv, rt)
  if not rt then return end
  if rt.priority then argv[#argv + 1] = "--rt-priority" argv[#argv + 1] = argstr(rt.priority) end
  if rt.cpu then argv[#argv + 1] = "--rt-cpu" argv[#argv + 1] = argstr(rt.cpu) end
end

-- The argv that starts `child` (a spec child) through the daemon at `addr`.
local function child_argv(child, addr, key)
  local argv
  if child.kind == "leaf" then
    argv = { "dca", "node", "--type", child.type, "--name", child.path, "--daemon", addr }
  else
    argv = { "dca", "supervise", "--name", child.path, "--daemon", addr }
  end
  if key then argv[#argv + 1] = "--key" argv[#argv + 1] = key end
  if child.kind == "leaf" and child.package then
    -- the node loads its type's package by name, on its own host's search path (ARCHITECTURE.md, packages)
    argv[#argv + 1] = "--package" argv[#argv + 1] = child.package
    if child.system_dir then argv[#argv + 1] = "--system-dir" argv[#argv + 1] = child.system_dir end
  end
  if child.kind == "leaf" then rt_argv(argv, child.rt) end
  if child.kind == "leaf" then
    argv[#argv + 1] = "--"
    for _, a in ipairs(child.args or {}) do argv[#argv + 1] = argstr(a) end
  end
  return argv
end
M.child_argv = child_argv

-- ---------------------------------------------------------------------------------------------------------
-- A started process: its daemon's child id, its exit, the bounded kill.
-- ---------------------------------------------------------------------------------------------------------
local Proc = {}
Proc.__index = Proc
M.Proc = Proc   -- (tests/lua/supervisor/net_test.lua builds one over a fake daemon)

-- Its exit (event or host lost) is heard by every waiter once.
function Proc:gone()
  if self.kill_timer then self.kill_timer:cancel() self.kill_timer = nil end
  local waiters = self.on_exit
  self.on_exit = nil
  for _, w in ipairs(waiters or {}) do w(true) end
end

-- Marks it exited and tells its supervisor (unless the runtime is closing); closes its channel. `lost`: its host
-- or channel was lost (the policy's `lost` fault; the reason is only shown). `host_lost`: its host's daemon was
-- lost, which the clock master may never count (a fenced node leaves the clock in order): told at once, in
-- lock-step too (a lost host is outside the exact semantics, docs/time.md).
function Proc:exited_with(rt, reason, _, lost, host_lost)
  if self.exited then return end
  if self.unreached then
    -- it ended before it was reached (a failed start: its reason came with the exit): its start fails now
    self.exited = true
    self.unreached(reason)
    return
  end
  -- (the end of a process killed because its channel was lost: Proc:channel_closed)
  if self.lost_reason then reason, lost, self.lost_told = self.lost_reason, true, true end
  self.exited = true
  if self.lost_timer then self.lost_timer:cancel() end
  -- a leaf that ends without being asked is what the clock master counts as a lost node: in lock-step its
  -- exit waits for the barrier (Net:_quiesce)
  if self.kind == "leaf" and not self.stopping and rt.ls.joined and not rt.closing then
    rt.ls.exited[self.path] = (rt.ls.exited[self.path] or 0) + 1
    if host_lost then
      rt.ls.received = rt.ls.received + 1
      if rt.sup then rt.sup:child_exit(self.name, reason, lost) end
    else
      rt.ls.queue[#rt.ls.queue + 1] = { now = math.huge, name = self.name, exit = reason, lost = lost }
    end
    if self.ch and not self.ch_closed then self.ch:close() end
    return
  end
  if rt.sup and not rt.closing then rt.sup:child_exit(self.name, reason, lost) end
  if self.ch and not self.ch_closed then self.ch:close() end
end

function Proc:kill(sig)
  if self.exited then return end
  if self.shared then self.shared:remove(self) return end
  local rt = self.rt
  self.daemon:kill(self.child, sig or "TERM", function(_, kerr)
    if kerr and not self.exited and not rt.closing then rt.log(sformat("kill %s: %s", self.path, tostring(kerr))) end
  end)
end

-- Kills, then waits for the exit event (bounded): SIGKILL after `stop_grace` seconds, gives up after as many
-- again. cb(true) once gone | cb(nil, reason)
function Proc:kill_wait(sig, cb)
  if cb then
    if self.exited then cb(true) return end
    self.on_exit = self.on_exit or {}
    self.on_exit[#self.on_exit + 1] = cb
  end
  if self.exited or self.kill_timer then return end
  self:kill(sig)
  local grace = self.rt.opts.stop_grace or 5
  self.kill_timer = core.after(grace, function()
    if self.exited then return end
    self:kill("KILL")
    self.kill_timer = core.after(grace, function()
      self.kill_timer = nil
      if self.exited then return end
      local waiters = self.on_exit
      self.on_exit = nil
      for _, w in ipairs(waiters or {}) do
        w(nil, sformat("%s (pid %s on host %s) did not exit within %gs of SIGKILL", self.path,
          tostring(self.pid), self.host, grace))
      end
    end)
  end)
end

-- Its control channel closed while it should run: its exit event (with its signal) follows from its daemon,
-- or the daemon's loss does; this bound covers a process that closed its channel and lives on. Such a one is
-- lost: it is killed first (SIGKILL, the bounded wait of kill_wait), so that its restart leaves no old process
-- behind, and its end is told as `lost` (with its exit, or once the wait gave up).
function Proc:channel_closed(reason)
  self.ch_closed = true
  local rt = self.rt
  if rt.closing or self.exited or self.stopping or not rt.sup then return end
  self.lost_timer = core.after(rt.opts.exit_grace or 10, function()
    self.lost_timer = nil
    if self.exited or rt.closing then return end
    local why = sformat("%s lost on host %s: %s", self.kind == "group" and "supervisor" or "node", self.host,
      tostring(reason))
    self.lost_reason = why
    rt.log(sformat("%s (pid %s on host %s): %s; killed before its restart", self.path, tostring(self.pid),
      self.host, why))
    self:kill_wait("KILL", function(ok, err)
      if ok and self.lost_told then return end
      if not ok then rt.log(sformat("%s: %s", self.path, tostring(err))) end
      self.exited, self.lost_told = true, true
      if rt.sup and not rt.closing then rt.sup:child_exit(self.name, why, true) end
    end)
  end)
end

-- The handle the supervisor holds (see dca.supervisor: request, send, kill, lost, pid, host). Its requests
-- (but the heartbeat's pings) keep the supervisor busy for the lock-step's barrier until answered.
function Proc:handle()
  local ch, h, rt = self.ch, { pid = self.pid, host = self.host }, self.rt
  function h.request(msg, timeout, rcb)
    if msg.type == "ping" then ch:request(msg, timeout, rcb) return end
    ch:request(msg, timeout, rt.busy_while(rcb))
  end
  function h.send(msg) ch:send(msg) end
  function h.kill(sig, kcb)
    -- (in lock-step the barrier waits for the exit: a restart replaces the process at the tick it happens)
    if kcb then kcb = rt.busy_while(kcb) end
    self.stopping = true
    if self.lost_timer then self.lost_timer:cancel() end
    self:kill_wait(sig, kcb)
    ch:close()
  end
  function h.lost()
    self.exited = true
    if self.lost_timer then self.lost_timer:cancel() end
  end
  return h
end

-- ---------------------------------------------------------------------------------------------------------
-- A shared node this runtime placed leaves in: its daemon child, its own control channel, its leaves (Procs).
-- ---------------------------------------------------------------------------------------------------------
local Shared = {}
Shared.__index = Shared
M.Shared = Shared  -- (tests/lua/supervisor/net_test.lua opens one over a fake daemon)

--- The name of the shared node a leaf goes to under `placement`: one per group and host, or one per run and
--- host (the run named by its root). nil for "process".
function M.shared_name(placement, child, group_path)
  if placement == "group" then return sformat("leaves:%s@%s", group_path, child.host) end
  if placement == "host" then return sformat("leaves:%s@%s", child.path:match("^[^.]+"), child.host) end
  return nil
end

-- Runs fn(self) once the node is reached (now, or when it is), or fn(nil, err) if it cannot be.
function Shared:when_ready(fn)
  if self.ch then fn(self) return end
  if self.error then fn(nil, self.error) return end
  self.waiters[#self.waiters + 1] = fn
end

function Shared:_ready(err)
  self.error = err
  if err and self.rt.shared[self.name] == self then self.rt.shared[self.name] = nil end  -- a later spawn retries
  local ws = self.waiters
  self.waiters = {}
  for _, w in ipairs(ws) do if err then w(nil, err) else w(self) end end
end

-- Spawns or joins the shared node through the daemon `dc`, then connects to its own control address.
function Shared:open(dc)
  local rt = self.rt
  local argv = { "dca", "node", "--shared", self.name, "--daemon", rt.opts.hosts[self.host] }
  if rt.opts.key then argv[#argv + 1] = "--key" argv[#argv + 1] = rt.opts.key end
  rt_argv(argv, self.rt_setting)
  dc:spawn(argv, rt._spawn_opts(self.host, { name = self.name, shared = true }), clients.result(function(r, err)
    if not r then self:_ready(err) return end
    self.child, self.pid = r.child, r.pid
    rt.by_child[self.host .. ":" .. tostring(r.child)] = self
    local reg = self.name .. "#" .. tostring(r.pid)
    clients.open(dc, reg, rt.timeouts.lookup, clients.key_opts(rt.opts.key), clients.Plain, function(c, oerr)
      if not c then self:_ready(sformat("shared node %s on host %s: %s", reg, self.host, tostring(oerr))) return end
      self.ch = c.channel
      c:on_close(function() self.ch = nil self.error = "shared node " .. reg .. " closed its channel" end)
      self:_ready(nil)
    end)
  end))
end

-- Adds leaf `child` (resolved) and reaches it at its own control address: cb(handle) | cb(nil, reason).
function Shared:add(child, cb)
  local rt = self.rt
  local args = {}
  for i, a in ipairs(child.args or {}) do args[i] = M.argstr(a) end
  -- (the node loads the type's package by name, as a one-leaf node does with --package; on the wall clock it runs
  -- the leaf on the real-time thread of its group's rt { }, one thread per distinct setting: host/node.h)
  self.ch:request({ type = "add", controller = child.type, name = child.path, args = args, package = child.package,
                    system_dir = child.package and child.system_dir or nil, rt = child.rt }, rt.timeouts.spawn,
    clients.result(function(r, err)
      if not r then cb(nil, err) return end
      local p = setmetatable({ rt = rt, daemon = self.dc, name = child.name, host = child.host, kind = "leaf",
                               child = self.child, pid = self.pid, path = child.path, shared = self }, Proc)
      self.leaves[p] = true
      clients.connect(r.control, clients.key_opts(rt.opts.key), clients.Plain, function(c, cerr)
        if not c then p:kill_wait("KILL") cb(nil, sformat("%s at %s: %s", child.path, r.control, tostring(cerr))) return end
        rt._attach(p, c, cb)
      end)
    end))
end

-- Removes leaf Proc `p` from the node (Stop, then its instance destroyed): its end. The last leaf this runtime
-- placed here lets go of the node (the daemon ends it when nobody holds it).
function Shared:remove(p)
  local function gone()
    if p.exited then return end
    p.exited = true
    self.leaves[p] = nil
    -- (let go first: a waiter told of the end may place a leaf at once, in a node of its own)
    if next(self.leaves) == nil then self:release() end
    p:gone()
  end
  if not self.ch then gone() return end
  self.ch:request({ type = "remove", name = p.path }, self.rt.opts.stop_grace or 5, function() gone() end)
end

-- Lets go of the node (this runtime places nothing more in it).
function Shared:release()
  local rt = self.rt
  if rt.shared[self.name] == self then rt.shared[self.name] = nil end
  if self.ch then self.ch:close() self.ch = nil end
  if self.child and not self.ended then self.dc:request({ type = "release", child = self.child }, nil, function() end) end
end

-- The node ended (exit event `msg`, or its host lost): each of its leaves ends with the reason, named per leaf;
-- the leaf whose code crashed (msg.culprit: the node's crash note, host/node.h) comes first, then path order.
function Shared:exited_with(rt, reason, msg, lost, host_lost)
  if self.ended then return end
  self.ended = true
  if rt.shared[self.name] == self then rt.shared[self.name] = nil end
  local list, culprit = {}, msg and msg.culprit
  for p in pairs(self.leaves) do list[#list + 1] = p end
  table.sort(list, function(a, b)
    if (a.path == culprit) ~= (b.path == culprit) then return a.path == culprit end
    return a.path < b.path
  end)
  local in_it = list[1] and list[1].path == culprit and sformat("; it crashed in %s", culprit) or ""
  local why = sformat("%s (shared node %s#%s, %d leaves%s)", reason, self.name, tostring(self.pid), #list, in_it)
  local names = {}
  for _, p in ipairs(list) do
    if not p.exited then
      p.exited = true
      if p.lost_timer then p.lost_timer:cancel() end
      names[#names + 1] = p.name
    end
  end
  if rt.sup and not rt.closing and #names > 0 then
    if rt.ls.joined then for _, p in ipairs(list) do rt.ls.exited[p.path] = (rt.ls.exited[p.path] or 0) + 1 end end
    if rt.ls.joined and not host_lost then  -- in lock-step the exits wait for the barrier (Net:_quiesce), one per leaf
      rt.ls.queue[#rt.ls.queue + 1] = { now = math.huge, name = names[1], exits = names, exit = why, lost = lost }
    else
      if rt.ls.joined then rt.ls.received = rt.ls.received + #names end
      rt.sup:children_exit(names, why, lost)
    end
  end
  for _, p in ipairs(list) do if p.ch and not p.ch_closed then p.ch:close() end end
end

function Shared:gone()
  for p in pairs(self.leaves) do p:gone() end
  self.leaves = {}
end

-- ---------------------------------------------------------------------------------------------------------
-- The runtime: new(opts) binds these methods as rt.name(...) (the supervisor calls them so).
-- ---------------------------------------------------------------------------------------------------------
local Net = {}
-- (busy_while, the lock-step barrier and the clock: dca.supervisor.lockstep)
for name, f in pairs(require "dca.supervisor.lockstep") do Net[name] = f end

function Net:bind(s) self.sup = s end
function Net:now() return core.now() end
function Net:defer(fn)
  local f = self.busy_while(fn)
  return core.after(0, function() f() end)
end
function Net:after(s, fn) return core.after(s, fn) end
function Net:every(s, fn) return core.every(s, fn) end
function Net:report(msg)
  if self.opts.to_parent and (msg.type == "done" or msg.type == "aborted") then self.ls.sent = self.ls.sent + 1 end
  if self.opts.report then self.opts.report(msg) end
end

function Net:log(line) if self.opts.log then self.opts.log(line) end end
-- The manifests: the built-ins and the packages of this group's leaves (loaded here too, so that a child
-- supervisor on another host knows their device ports; one that fails to load fails its node's start instead).
function Net:types()
  if not core.types then return {} end
  local spec = self.sup and self.sup.spec
  for _, c in ipairs(spec and spec.children or {}) do
    if c.kind == "leaf" and c.package and core.load_package then core.load_package(c.package, c.system_dir) end
  end
  return core.types()
end

--- The heartbeat period and the silence after which a daemon or a child supervisor is lost (seconds):
--- opts.heartbeat = { period, timeout }, default 1 and 5 (generous: a loaded machine answers late, a stopped
--- process never). The period is at most a quarter of the fence (a daemon hears three renewals within it), the
--- silence at most the fence (past it the host's leaves have stopped: waiting longer only delays the failover).
function Net:heartbeat()
  local hb, fence = self.opts.heartbeat or {}, self.fencing()
  return math.min(hb.period or hb[1] or 1, fence / 4), math.min(hb.timeout or hb[2] or 5, fence)
end

--- This group's fencing (docs/supervision.md, "Fencing"): fence, margin (seconds; spec.fence, else 5 and 1).
function Net:fencing()
  local f = self.sup and self.sup.spec and self.sup.spec.fence or {}
  return f.fence or 5, f.margin or 1
end

-- A renewal of the leases this supervisor holds at `host`'s daemon is sent now (a ping or a fenced spawn): the
-- time on this host's monotonic clock.
function Net:_renewing(host) self.renewed[host] = core.now() end

--- Calls cb(waited) once every lease this supervisor held at `host`'s daemon has lapsed: `fence + margin`
--- after the last renewal sent there (at once when none was; waited = the seconds waited, else nil). A standby
--- starts after it, so a cut-off host's leaves have stopped by then (they stop `fence` after the last renewal
--- they heard, and none can be heard later than it was sent).
--- A daemon that closed its channel itself (its end of it, or its process, gone: a FIN or its error frame, not a
--- reset) fenced its children at once, or died and took them with it (they die with their parent): then the wait is
--- only the margin after the close (the SIGKILL of a child deaf to SIGTERM comes at half of it).
function Net:fenced(host, cb)
  local fence, margin = self.fencing()
  local last, closed = self.renewed[host], self.peer_closed[host]
  local wait = last and last + fence + margin - core.now()
  if wait and closed and closed >= last then wait = closed + margin - core.now() end
  if not wait or wait <= 0 then cb(nil) return end
  core.after(wait, self.busy_while(function() cb(wait) end))
end

-- A line a process started here wrote to its stderr, or how many of them its daemon left out (docs/processes.md,
-- "Output"): said by the supervisor at the process's path (a shared node's name).
function Net:_output(host, msg)
  local p = self.by_child[host .. ":" .. tostring(msg.child)]
  if not (p and self.sup) then return end
  local line = msg.line
  if msg.dropped then
    line = sformat("(%s lines of its output left out here: too many too fast; the log of host %s's daemon has them)",
      tostring(msg.dropped), host)
  end
  self.sup:output(p.path or p.name, tostring(line))
end

-- Every child on `host` is lost (its daemon closed or stopped answering).
function Net:_host_lost(host, reason)
  for _, p in pairs(self.by_child) do
    if p.host == host then
      p:exited_with(self, reason, nil, true, true)
      p:gone()
    end
  end
end

local function host_names(hosts)
  local t = {}
  for k in pairs(hosts) do t[#t + 1] = k end
  table.sort(t)
  return concat(t, ", ")
end

-- The client of `host`'s daemon (connected once; its loss loses every child on that host). cb(d) | cb(nil, err)
function Net:daemon(host, cb)
  local d = self.daemons[host]
  if d and d.client then cb(d.client) return end
  if d then d.waiters[#d.waiters + 1] = cb return end
  local addr = self.opts.hosts[host]
  if not addr then
    cb(nil, sformat("no daemon for host '%s' (hosts: %s)", tostring(host), host_names(self.opts.hosts)))
    return
  end
  d = { waiters = { cb } }
  self.daemons[host] = d
  daemon_client.connect(addr, clients.key_opts(self.opts.key), function(dc, err)
    local waiters = d.waiters
    d.waiters = {}
    if not dc then
      self.daemons[host] = nil
      for _, w in ipairs(waiters) do w(nil, sformat("daemon of host %s at %s: %s", host, addr, tostring(err))) end
      return
    end
    d.client = dc
    self._watch_daemon(host, d, dc)
    for _, w in ipairs(waiters) do w(dc) end
  end)
end

-- A daemon's events (exits, configuration changes), its close and its heartbeat: one that does not answer a
-- ping within the silence bound is lost (a stopped or wedged daemon keeps its socket open: only silence tells).
function Net:_watch_daemon(host, d, dc)
  dc:on_event(function(msg)
    if msg.type == "output" then self._output(host, msg) return end
    if d.config then d.config:event(msg) end
  end)
  dc:on_exit(function(msg)
    local p = self.by_child[host .. ":" .. tostring(msg.child)]
    if not p then return end
    local reason = daemon_client.describe_exit(msg, host)
    -- killed by this supervisor for a known cause (a stall the clock master saw): the cause first
    if p.kill_why then reason = sformat("%s; %s", p.kill_why, reason) end
    p:exited_with(self, reason, msg)
    p:gone()
  end)
  local beat, closed
  dc:on_close(function(reason)
    closed = true  -- (its heartbeat ends here: a ping failing on this closed channel is no second loss)
    if beat then beat:cancel() end
    local r = tostring(reason)
    if r:find("^connection closed by the peer") or r:find("^closed by the peer") then self.peer_closed[host] = core.now() end
    if self.daemons[host] == d then self.daemons[host] = nil end
    self._host_lost(host, sformat("host %s lost (daemon gone: %s)", host, tostring(reason)))
  end)
  local hb, hb_timeout = self.heartbeat()
  beat = core.every(hb, function()
    if self.closing or closed or d.client ~= dc then beat:cancel() return end
    self._renewing(host)
    dc:request({ type = "ping" }, hb_timeout, function(r, perr)
      if r or closed or d.client ~= dc or self.closing then return end
      beat:cancel()
      if self.daemons[host] == d then self.daemons[host] = nil end
      self._host_lost(host, sformat("host %s lost (its daemon did not answer for %gs: %s)", host, hb_timeout,
        tostring(perr)))
      dc:close()
    end)
  end)
end

--- Starts `child` (a spec child) inactive on its host; cb(handle) | cb(nil, reason). A leaf's `config("key")`
--- arguments are read first from the configuration replica of its host's daemon (dca.config), checked against
--- the parameter's type: a missing key or a wrong type fails the start, naming the parameter and the key.
function Net:spawn(child, cb)
  -- in lock-step the supervisor is busy until the process is up: a (re)start at a barrier takes effect at its tick
  cb = self.busy_while(cb)
  self.daemon(child.host, function(dc, err)
    if not dc then cb(nil, err) return end
    spec_mod.resolve_leaf(child, config.over_channel(dc.channel, self.timeouts.lookup), function(c, rerr)
      if not c then cb(nil, rerr) return end
      self._start(c, dc, cb)
    end)
  end)
end

-- Spawns the resolved `child` through its daemon `dc`, then reaches it (see _reach); a leaf under a shared
-- placement is added to its shared node instead (spawned or joined once per name).
function Net:_start(child, dc, cb)
  local sname = child.kind == "leaf" and M.shared_name(self.opts.placement, child, self.sup and self.sup.path)
  if sname then
    local sh = self.shared[sname]
    if not sh then
      -- one group's leaves (placement group) share its rt { }; a node of the whole host's (placement host) takes
      -- none of its own: each leaf's `add` names its group's, and the node runs one real-time thread per setting
      sh = setmetatable({ rt = self, dc = dc, name = sname, host = child.host, leaves = {}, waiters = {},
                          rt_setting = self.opts.placement == "group" and child.rt or nil }, Shared)
      self.shared[sname] = sh
      sh:open(dc)
    end
    sh:when_ready(function(s, err)
      if not s then cb(nil, err) return end
      s:add(child, cb)
    end)
    return
  end
  local argv = child_argv(child, self.opts.hosts[child.host], self.opts.key)
  dc:spawn(argv, self._spawn_opts(child.host, { name = child.path }), clients.result(function(r, err)
    if not r then cb(nil, err) return end
    local p = setmetatable({ rt = self, daemon = dc, name = child.name, host = child.host, kind = child.kind,
                             child = r.child, pid = r.pid, path = child.path }, Proc)
    self.by_child[child.host .. ":" .. tostring(r.child)] = p  -- child ids are per daemon
    self._reach(p, dc, cb)
  end))
end

-- The options of a spawn on `host`'s daemon: `o` with the spawn timeout and this group's fencing (its child is
-- fenced when this supervisor is silent; SIGKILL at half the margin). The spawn renews the lease.
function Net:_spawn_opts(host, o)
  local fence, margin = self.fencing()
  o.timeout, o.fence, o.kill_after = self.timeouts.spawn, fence, margin / 2
  self._renewing(host)
  return o
end

-- Looks the started process up by its path and connects to its control endpoint; a process that cannot be
-- reached is killed. One that ends first (its exit event, with the reason it gave) fails the start at once:
-- cb(nil, reason, "exited"). cb(handle) | cb(nil, reason[, "exited"])
function Net:_reach(p, dc, cb)
  local answered = false
  p.unreached = function(reason)
    answered, p.unreached = true, nil
    cb(nil, reason, "exited")
  end
  clients.open(dc, p.path, self.timeouts.lookup, clients.key_opts(self.opts.key), clients.Plain, function(c, err)
    if answered then if c then c:close() end return end
    answered, p.unreached = true, nil
    if not c then p:kill_wait("KILL") cb(nil, err) return end
    self._attach(p, c, cb)
  end)
end

-- The control client `c` of the started process `p`: its events go to the supervisor. cb(handle)
function Net:_attach(p, c, cb)
  p.ch = c.channel
  if p.kind == "leaf" then self.my_leaves[p.path] = true end
  c.channel:on_message(function(msg, id)
    if (id or 0) == 0 and self.sup then self._child_event(p, msg) end
  end)
  c:on_close(function(reason) p:channel_closed(reason) end)
  cb(p:handle())
end

--- Kills (SIGKILL) every process the lost child supervisor of `group` had started: the daemons of its
--- subtree's hosts are asked which of their children bear a path below it; its leaves in shared nodes (which
--- other supervisors may hold) are ended one by one (`exit` on each leaf's control channel removes it from its
--- node). Best effort, nothing awaited.
function Net:reap(group)
  local prefix = group.path .. "."
  local seen = {}
  local function visit(spec)
    for _, c in ipairs(spec.children or {}) do
      if c.host then seen[c.host] = true end
      if c.kind == "leaf" and self.opts.placement and self.opts.placement ~= "process" then self._reap_leaf(c) end
      if c.kind == "group" and c.spec then visit(c.spec) end
    end
  end
  visit(group.spec or group)
  for host in pairs(seen) do
    self.daemon(host, function(dc)
      if not dc then return end
      dc:status(function(r)
        for _, c in ipairs(r and r.children or {}) do
          if type(c.name) == "string" and c.name:sub(1, #prefix) == prefix then dc:kill(c.child, "KILL") end
        end
      end)
    end)
  end
end

-- A leaf of a lost supervisor, if it lives in a shared node: asked to exit (its node removes it).
function Net:_reap_leaf(leaf)
  self.daemon(leaf.host, function(dc)
    if not dc then return end
    clients.lookup(dc, leaf.path, 0, function(ep)
      if not (ep and ep.shared and ep.control) then return end
      clients.connect(ep.control, clients.key_opts(self.opts.key), clients.Plain, function(c)
        if c then c:request({ type = "exit" }, nil, function() c:close() end) end
      end)
    end)
  end)
end

-- This supervisor's host: opts.daemon_host, else the first host name.
function Net:own_host()
  if self.opts.daemon_host then return self.opts.daemon_host end
  local names = {}
  for h in pairs(self.opts.hosts or {}) do names[#names + 1] = h end
  table.sort(names)
  return names[1]
end

--- The configuration repository of this supervisor's host (opts.daemon_host, else the first host): a
--- dca.config client over that daemon's channel, its watch events delivered. cb(client) | cb(nil, err)
function Net:config_client(cb)
  local host = self.own_host()
  self.daemon(host, function(dc, derr)
    if not dc then cb(nil, derr) return end
    local d = self.daemons[host]
    if not d.config then d.config = config.over_channel(dc.channel) d.config.host = host end
    cb(d.config)
  end)
end

--- A request to the robot process registered as `world` (dca sim --serve, or a robot's driver), looked up at
--- the daemon of this supervisor's host (lookups reach the peers) and reached on its control channel (opened
--- once). cb(reply) | cb(nil, err, missing)
function Net:world(msg, timeout, cb)
  cb = self.busy_while(cb)
  local w = self._world
  if w and w.client then w.client:request(msg, timeout, cb) return end
  local function go(c, err, missing)
    if c then c:request(msg, timeout, cb) else cb(nil, err, missing) end
  end
  if w then w.waiters[#w.waiters + 1] = go return end
  w = { waiters = { go } }
  self._world = w
  local function finish(c, err, missing)
    local ws = w.waiters
    w.waiters = {}
    if c then w.client = c else self._world = nil end
    for _, f in ipairs(ws) do f(c, err, missing) end
  end
  self._open_world(w, finish)
end

-- Looks the world up and connects to it: finish(client) | finish(nil, err, missing).
function Net:_open_world(w, finish)
  local host, name = self.own_host(), self.opts.world_name or "world"
  self.daemon(host, function(dc, derr)
    if not dc then finish(nil, derr) return end
    clients.open(dc, name, self.opts.world_wait or 5, clients.key_opts(self.opts.key), clients.Plain,
      function(c, err, missing)
        if missing then
          finish(nil, sformat("no process is registered as `%s` (asked the daemon of host %s: %s)", name, host,
            tostring(err)), true)
          return
        end
        if not c then finish(nil, err) return end
        c:on_close(function() if self._world == w then self._world = nil end end)
        function c._event(_, msg, id)
          if msg.type == "quiesce" and (id or 0) ~= 0 then self._quiesce(c.channel, id, msg) end
          if msg.type == "second_writer" and (id or 0) == 0 then self._second_writer(msg) end
        end
        finish(c)
      end)
  end)
end

-- The world refused a second writer on one of its inputs (`second_writer {input, writer, holder, now}`, each
-- writer "PATH.PORT"; docs/safety.md): an event of the refused writer's leaf, if this supervisor started it.
function Net:_second_writer(msg)
  local path = tostring(msg.writer):match("^(.+)%.[^.]+$")
  if not (path and self.my_leaves[path] and self.sup) then return end
  self.sup:child_message(path:match("[^.]+$"), msg)
end

--- Closes every daemon channel (after shutdown).
function Net:close()
  self.closing = true
  for _, sh in pairs(self.shared) do if sh.ch then sh.ch:close() end end
  for _, d in pairs(self.daemons) do if d.client then d.client:close() end end
  if self._world and self._world.client then self._world.client:close() end
end

--- The runtime over the hosts' daemons. opts: hosts = { name = addr }, key, exe, daemon_host, timeouts,
--- heartbeat, report(msg), log(line), stop_grace, exit_grace, world_name, world_wait (see the header).
function M.new(opts)
  local t = opts.timeouts or {}
  local rt = { opts = opts, daemons = {}, by_child = {}, shared = {}, closing = false, renewed = {}, peer_closed = {},
               ls = { received = 0, sent = 0, pending = 0, waiters = {}, per = {}, exited = {}, queue = {}, ended = {} },
               my_leaves = {},
               timeouts = { spawn = t.spawn or 10, lookup = t.lookup or 10 } }
  for name, f in pairs(Net) do
    rt[name] = function(...) return f(rt, ...) end
  end
  return rt
end

return M
