-- dca.scenario.real: the "real" backend of dca.scenario: local daemons (one per host name, loopback), the
-- root DCAS in this process, nodes and sub-supervisors as real processes. Same methods as the memory backend
-- (see dca.scenario); waits run this process's event loop with a wall-clock timeout.
local core, clients = require "dca.core", require "dca.clients"
local async = require "dca.async"
local spec_mod = require "dca.supervisor.spec"
local hosts_mod, start = require "dca.launch.hosts", require "dca.launch.start"

local M = {}

local ipairs, pairs, type, tostring, tonumber, sformat, error = ipairs, pairs, type, tostring, tonumber, string.format, error

local System = {}
System.__index = System

local function now() return core.now() end

-- Wall-clock waits only bound a hang: a scenario's timeout is in its system's time (exact in memory), and
-- here a loaded machine must never fail a step that is merely slow. Nothing timed is asserted.
local function bound(t) return math.min(20 + 4 * (t or 10), 100) end
M.bound = bound

-- A transition line ("main.a: running", "main.a: done 2", "main.g: aborted (...)") --> path, state
local WORD_STATE = { running = "running", done = "done", aborting = "stopping", stopped = "inactive",
                     aborted = "aborted", exited = "exited", lost = "lost", configured = "configured" }
local function transition(line)
  local path, word = tostring(line):match("^(%S+): (%a+)")
  return path, word and WORD_STATE[word]
end

function M.system(spec, opts)
  local s = setmetatable({ spec = spec, opts = opts, file = opts.file, root = opts.root, lines = {}, line_at = {},
                           seen = {}, backend = "real", outcome = nil, t0 = now() }, System)
  s.loop = core.loop()
  return s
end

-- Runs the loop until pred() or `timeout` seconds. --> true when pred() became true
function System:_until(pred, timeout)
  if pred() then return true end
  return self.loop:run_until(pred, timeout) and true or pred()
end

function System:_ask(fn, timeout, what)
  local res
  timeout = timeout or 30
  fn(function(...) res = table.pack(...) end)
  if not self:_until(function() return res ~= nil end, timeout) then
    error(sformat("timed out after %gs waiting for %s", timeout, what or "an answer"), 3)
  end
  return table.unpack(res, 1, res.n)
end

--- Starts one local daemon per host name and seeds their configuration repository as `dca run` does
--- (done by try_up when not yet). --> true | nil, reason
function System:start_hosts()
  if self.ctx then return true end
  local o = self.opts
  local so = { fresh_key = true, sim = o.sim, config = o.config, set = o.set, world_host = o.world_host,
               placement = o.placement or require("dca.scenario").placement }
  for _, k in ipairs(require("dca.clients.world").OPTIONS) do so[k] = so[k] or o[k] end
  local ctx = start.context(self.spec, so, { report = function(msg) self:_report(msg) end })
  local ok, err = start.hosts(ctx)
  if not ok then start.cleanup(ctx) return nil, err end
  self.ctx, self.daemons, self.key, self.keydir = ctx, ctx.daemons, ctx.key, ctx.keydir
  ctx.say = function(line) self.lines[#self.lines + 1] = line end  -- the seeding's line (not the hosts')
  ok, err = start.config(ctx)
  ctx.say = function() end
  return ok, err
end

-- A report of the root: transition lines (kept, and the states seen per path) and the outcome.
function System:_report(msg)
  self:_trace_line(msg)
  if msg.type == "log" then
    self.lines[#self.lines + 1] = msg.line
    if msg.at then self.line_at[#self.lines] = msg.at end
    local path, state = transition(msg.line)
    if state then
      self.seen[path] = self.seen[path] or {}
      self.seen[path][state] = true
    end
  elseif msg.type == "done" or msg.type == "aborted" then
    -- the outcome as in the memory backend ({type, value} | {type, path, reason}); `now` is kept apart
    self.outcome = { type = msg.type, value = msg.value, path = msg.path, reason = msg.reason }
    self.outcome_now = msg.now
  end
end

-- With a trace (opts.trace_file): the root's lines that carry their event's simulated time, and the outcome's
-- tick (where the trace ends), as `dca run --trace` keeps them (dca.launch.run).
function System:_trace_line(msg)
  if not self.opts.trace_file then return end
  local lines = self.trace_lines or {}
  self.trace_lines = lines
  if msg.type == "log" and msg.at then lines[#lines + 1] = { math.floor(msg.at * 1e9 + 0.5), msg.line } end
  if (msg.type == "done" or msg.type == "aborted") and tonumber(msg.now) then self.trace_end = tonumber(msg.now) end
  if msg.type == "done" and tonumber(msg.now) then
    lines[#lines + 1] = { tonumber(msg.now), sformat("%s: DONE %s", self.spec.path,
      require("dca.supervisor").show(msg.value)) }
  end
end

-- Before the stop, with a trace: time held once its tick has settled (its lines written), within 10 s.
function System:_hold_for_trace()
  if not (self.opts.trace_file and self.world and self.world:connected()) then return end
  pcall(function()
    self:world_hold()
    self:wait_world("time held, settled", function(st) return not st.running and st.settled end, 1)
  end)
end

-- After the world stopped: its trace and the transition lines merged into the trace file, cut at the outcome.
function System:_write_trace()
  local o = self.opts
  if not (o.trace_file and o.trace) then return end
  local ok, err = require("dca.trace").merge(o.trace, self.trace_lines or {}, o.trace_file, self.trace_end)
  os.remove(o.trace)
  if not ok then print("trace: " .. tostring(err)) end
end

--- Brings the system up (hosts, world, tree: dca.launch.start). --> true | nil, reason
function System:try_up(timeout)
  timeout = timeout or 30
  local hok, herr = self:start_hosts()
  if not hok then return nil, herr end
  local ctx = self.ctx
  if self.opts.sim and not self.world then
    ctx.o.wait = bound(timeout)
    local res = self:_ask(function(k) start.sequence(ctx, { "world" }, function(ok, werr) k({ ok, werr }) end) end,
      bound(timeout) + 5, "the world")
    if ctx.sim then
      self.world, self.world_host = ctx.sim.world, ctx.world_host
      self.world.on_lost = function(reason) self.world_lost = reason end
    end
    if not res[1] then return nil, res[2] end
  end
  self.sup = start.tree(ctx, self.world_host)
  self.rt = ctx.rt
  -- the emergency stop's presses and releases: the root's events (docs/safety.md), as in `dca run`
  if self.world then
    local requests = require "dca.supervisor.requests"
    self.world:watch_estop(function(ev) requests.estop_event(self.sup, ev, true) end)
  end
  local res = self:_ask(function(k) self.sup:configure(function(ok, cerr) k({ ok, cerr }) end) end, bound(timeout),
    "the start")
  if not res[1] then
    self:_ask(function(k) self.sup:shutdown(k) end, 100, "the stop after a failed start")
    return nil, res[2]
  end
  return true
end

function System:up(timeout)
  local ok, err = self:try_up(timeout)
  if not ok then error("start failed: " .. tostring(err), 0) end
  return true
end

function System:run(init)
  self.outcome = nil
  self.seen = {}
  if not self.world then self.sup:run_expr(init) return end
  -- simulated time starts once every process the start ran has its run (as `dca run --sim`)
  local went
  self.sup:run_expr(init, function()
    self.world:go(function(r, err) went = { r, err } end)
  end)
  self:wait("the world's go", function() return went ~= nil end, 10)
  if not went[1] then error("the world did not start its time: " .. tostring(went[2]), 2) end
end

-- The world (simulated time): its status, a port's latest value, hold / go. Raise without a world.
function System:_world(msg, what)
  if not self.world then error("this system has no world (S.system(file, { sim = WORLD }))", 3) end
  local res = self:_ask(function(k) self.world:request(msg, 10, function(r, err) k({ r, err }) end) end, 25, what)
  if not res[1] then error(what .. ": " .. tostring(res[2]) .. (self.world_lost and (" (" .. self.world_lost .. ")") or ""), 3) end
  return res[1]
end

--- The world's `status {}`: t (s), door_angle, handle_angle, base_pose {x, y, yaw}, latched, ... 
function System:world_status()
  local r = self:_world({ type = "status" }, "the world's status")
  r.t = tonumber(r.t)
  return r
end

--- The latest value of the world's port `port` (an input such as base.cmd_vel: the last command it received;
--- an output such as arm.q: the last sample it wrote). A vector as a Lua array.
function System:world_read(port)
  local r = self:_world({ type = "read", port = port }, "the world's " .. port)
  return r.value
end

--- Stops the world's time after the current tick. --> the time it holds at (s)
function System:world_hold()
  local r = self:_world({ type = "hold" }, "the world's hold")
  return (tonumber(r.now) or 0) / 1e9
end

--- Time flows (if held) and holds once it reaches `t` (seconds; the tick at or after it): waits until it has
--- and that tick has settled (its round and any barrier done: what happens at it has happened).
--- --> the time held at
function System:world_hold_at(t, timeout)
  self:world_hold_when(t)
  self:world_go()
  return self:world_wait_held(t, timeout)
end

--- Time will hold once it reaches `t` (seconds), set while it does not flow (before run(): a run whose time
--- flows faster than the scenario asks is held at a known tick all the same); world_wait_held(t) then waits for it.
function System:world_hold_when(t)
  self:_world({ type = "hold", at = math.floor(t * 1e9 + 0.5) }, "the world's hold")
end

--- Waits until time holds at `t` or after and that tick has settled. --> the time held at
function System:world_wait_held(t, timeout)
  return self:wait_world(sformat("time held at %g s, settled", t),
    function(s) return not s.running and s.settled and s.t >= t - 1e-9 end, timeout).t
end

--- Lets the world's time flow again.
function System:world_go() self:_world({ type = "go" }, "the world's go") end

--- Waits until pred(world status) holds (each check a status request), bounded. --> the status
function System:wait_world(what, pred, timeout)
  local b = bound(timeout)
  local deadline, st = now() + b, nil
  while true do
    st = self:world_status()
    if pred(st) then return st end
    if now() > deadline then break end
    self:settle(0.005)
  end
  error(sformat("timed out after %gs (wall clock) waiting for the world: %s (t=%s)", b, what, tostring(st and st.t)), 2)
end

function System:settle(s) self.loop:run_until(function() return false end, s or 0) end

function System:wait(what, pred, timeout)
  local b = bound(timeout)
  if not self:_until(pred, b) then
    error(sformat("timed out after %gs (wall clock) waiting for %s", b, what), 2)
  end
end

function System:wait_outcome(timeout)
  self:wait("the root's outcome", function() return self.outcome ~= nil end, timeout)
  self:_until(function() return (self.sup.stops_pending or 0) == 0 end, bound(timeout))
  return self.outcome
end

function System:state(path)
  local tree = self:_ask(function(k) self.sup:tree(k) end, 25, "the tree")
  local n = require("dca.supervisor").find(tree, path)
  return n and n.state
end

-- Waits until `path` has been in `state` since the last run() (from the transition lines its owner sends
-- up, so a short state is never missed), or is in it now.
function System:wait_state(path, state, timeout)
  local function seen() return self.seen[path] ~= nil and self.seen[path][state] == true end
  if seen() or self:state(path) == state then return end
  local b = bound(timeout)
  if not self:_until(seen, b) then
    error(sformat("timed out after %gs (wall clock) waiting for %s %s (now %s)", b, path, state,
      tostring(self:state(path))), 2)
  end
end

-- Reads `path`.`port` until pred(value) holds (each read a request to the node), bounded.
function System:wait_read(path, port, pred, timeout)
  local b = bound(timeout)
  local deadline, v = now() + b, nil
  while true do
    v = self:read(path, port)
    if pred(v) then return v end
    if now() > deadline then break end
    self:settle(0.01)
  end
  error(sformat("timed out after %gs (wall clock) waiting for %s.%s (last value %s)", b, path, port, tostring(v)), 2)
end

function System:inject(path, kind, value)
  local msg = kind == "done" and { type = "done", value = value } or { type = "aborted", reason = value or "injected" }
  local ok, err = self:_ask(function(k) self.sup:inject(path, msg, k) end, 25, "the injection")
  if not ok then error("inject " .. path .. ": " .. tostring(err), 2) end
end

-- The daemon channel of `host` (opened once for the scenario's own questions).
function System:_daemon(host)
  self.dchs = self.dchs or {}
  if self.dchs[host] then return self.dchs[host] end
  local d, err = self:_ask(function(k)
    require("dca.clients.daemon").connect(self.daemons.hosts[host], clients.key_opts(self.key), k)
  end, 25, "the daemon of " .. host)
  if not d then error("daemon " .. host .. ": " .. tostring(err), 3) end
  self.dchs[host] = d
  return d
end

--- The configuration repository of `host`'s daemon (default: the first host): get(key), set(key, value) or
--- set{ key = value } (one transaction), list(prefix), log(n), watch(prefix) --> a list the changes below
--- prefix are appended to ({ key, value, origin }), local or replicated (sys:wait lets them arrive). Errors raise.
function System:config(host)
  host = host or spec_mod.hosts(self.spec)[1]
  self.configs = self.configs or {}
  if self.configs[host] then return self.configs[host] end
  local addr = self.daemons and self.daemons.hosts[host]
  if not addr then error("no daemon for host " .. tostring(host) .. " (is the system up?)", 2) end
  local config = require "dca.config"
  local c, err = config.sync(addr, { key_file = self.key })
  if not c then error("configuration repository of host " .. host .. ": " .. tostring(err), 2) end
  local function check(v, e)
    if e then error("configuration repository of host " .. host .. ": " .. tostring(e), 3) end
    return v
  end
  local repo = {}
  function repo.get(_, key) return check(c:get(key)) end
  function repo.set(_, key, value)
    return check(c:set(type(key) == "table" and key or { [key] = value }))
  end
  function repo.list(_, prefix) return check(c:list(prefix)) end
  function repo.log(_, n) return check(c:log(n)) end
  function repo.watch(_, prefix)
    local events = {}
    check(c:watch(prefix or "", function(ev) events[#events + 1] = ev end))
    return events
  end
  repo.client = c
  self.configs[host] = repo
  return repo
end

-- The pid of the process registered as `path` (node or supervisor), from its host's daemon.
function System:pid(path)
  local host
  spec_mod.walk_all(self.spec, function(n) if n.path == path then host = n.host end end)
  if not host then error("no process " .. path, 3) end
  local r = self:_ask(function(k) self:_daemon(host):request({ type = "status" }, 20, k) end, 25,
    "the daemon's status of host " .. host)
  for _, c in ipairs(r and r.children or {}) do
    if c.name == path then return c.pid end
  end
  -- a leaf in a shared node (dca run --placement group|host) is no daemon child: its registration has the pid
  local ep = self:_ask(function(k) clients.lookup(self:_daemon(host), path, 0, k) end, 25, "the lookup of " .. path)
  return ep and ep.shared and ep.pid or nil
end

-- Whether process `pid` has ended: gone, or a zombie its parent has not reaped yet (its descriptors are closed).
local function ended(pid)
  local f = io.open("/proc/" .. pid .. "/stat")
  if not f then return true end
  local stat = f:read("a") or ""
  f:close()
  local state = stat:match("%) (%a)")
  return state == nil or state == "Z" or state == "X"
end

-- The signals that end a node (its handlers stop it on TERM and INT).
local ending = { KILL = true, SEGV = true, ABRT = true, BUS = true, FPE = true, ILL = true, TERM = true, INT = true,
                 QUIT = true }

-- Sends `sig` (default KILL) to the process of `path`; a signal that ends it returns once it has ended. A signal
-- is delivered asynchronously: without the wait, time released right after a kill can meet the process still
-- answering the next advance in one run and gone in another, and the traces differ (scenario_repeat.sh).
function System:kill(path, sig)
  local pid = self:pid(path)
  if not pid then error("no live process " .. path, 2) end
  sig = sig or "KILL"
  assert(core.kill(pid, sig))
  local name = sig:gsub("^SIG", "")
  if not ending[name] then return end
  self:_until_ended(pid, path, "SIG" .. name)
end

-- Returns once process `pid` (`what`, for the error) has ended, within 10 s (wall clock) of `cause`.
function System:_until_ended(pid, what, cause)
  local deadline = now() + 10
  while not ended(pid) do
    if now() > deadline then
      error(sformat("%s (pid %d) has not ended 10 s (wall clock) after %s", what, pid, cause), 3)
    end
    self:settle(0.001)
  end
end

function System:freeze(path)
  local pid = self:pid(path)
  if not pid then error("no live process " .. path, 2) end
  assert(core.kill(pid, "STOP"))
end

function System:freeze_host(host)
  local pid = self.daemons.pids[host]
  if not pid then error("no host " .. host, 2) end
  assert(core.kill(pid, "STOP"))
end

function System:exists(path) return self:pid(path) ~= nil end

function System:lose_host(host)
  local pid = self.daemons.pids[host]
  if not pid then error("no host " .. host, 2) end
  -- its children go with it, the daemon first: they are held (SIGSTOP) so that they neither close their
  -- channels nor stop on their daemon's death (host/spawn.h) before the daemon is gone, as when a host is cut off
  local children = self:_host_pids(host)
  for _, p in ipairs(children) do core.kill(p, "STOP") end
  assert(core.kill(pid, "KILL"))
  for _, p in ipairs(children) do core.kill(p, "KILL") end
  self:_until_ended(pid, "the daemon of host " .. host, "SIGKILL")
  for _, p in ipairs(children) do self:_until_ended(p, "a process of host " .. host, "SIGKILL") end
end

-- Processes started by the daemon of `host` (from /proc: their parent is the daemon).
function System:_host_pids(host)
  local dpid = self.daemons.pids[host]
  local list = {}
  for _, pid in ipairs(core.list_dir("/proc") or {}) do
    if pid:match("^%d+$") then
      local f = io.open("/proc/" .. pid .. "/stat")
      local st = f and f:read("l") or ""
      if f then f:close() end
      local ppid = st:match("^%d+ %b() %a (%d+)")
      if ppid and tonumber(ppid) == dpid then list[#list + 1] = tonumber(pid) end
    end
  end
  return list
end

function System:drop(path, set)
  local r = self:_ask(function(k) self.sup:to_leaf(path, { type = "deactivate", set = set }, 20, k) end, 25, "the drop")
  local ok, why = async.outcome(r)
  if not ok then error("drop " .. path .. " " .. set .. ": " .. why, 2) end
end

function System:read(path, port)
  local r = self:_ask(function(k) self.sup:to_leaf(path, { type = "read", port = port }, 20, k) end, 25, "the read")
  local ok, why = async.outcome(r)
  if not ok then error("read " .. path .. "." .. port .. ": " .. why, 2) end
  local v = r.value
  if type(v) == "table" and #v == 1 then v = v[1] end
  return v
end

function System:transitions() return self.lines end
--- The simulated time (s) of transition line i, for a line that carries its event's time (in simulated time).
function System:transition_at(i) return self.line_at[i] end

function System:alive()
  local list = {}
  if not self.daemons then return list end
  for _, h in ipairs(self.daemons.order) do
    if hosts_mod.alive(self.daemons.pids[h]) then
      for _, p in ipairs(self:_host_pids(h)) do list[#list + 1] = p end
    end
  end
  return list
end

function System:now() return now() - self.t0 end

function System:reload(file)
  local opts = { root = self.root, world = self.opts.sim }
  return self:_ask(function(k) require("dca.reload").system(self.sup, file or self.file, opts, k) end,
    10, "the reload")
end

function System:stop()
  for _, r in pairs(self.configs or {}) do r.client:close() end
  self.configs = nil
  self:_hold_for_trace()
  if self.sup then self:_ask(function(k) self.sup:shutdown(k) end, 100, "the stop") end
  if self.world then
    -- then the world (a child of its host's daemon, so counted by alive())
    local stopped = false
    self.world:stop(function() stopped = true end)
    self:_until(function() return stopped end, 20)
    self.world:close()
    self:_write_trace()
  end
  -- the shutdown saw every exit event; the daemons reap their children just after: a bounded check
  local deadline = now() + 15
  local left = self:alive()
  while #left > 0 and now() < deadline do
    self:settle(0.01)
    left = self:alive()
  end
  for _, ch in pairs(self.dchs or {}) do ch:close() end
  if self.ctx then start.cleanup(self.ctx) end
  self.stopped = true
  return #left == 0, left
end

return M
