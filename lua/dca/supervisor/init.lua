-- dca.supervisor: the DCAS of the paper (section 4.1), one per process-group instance.
--
-- Pure logic: every effect goes through a runtime `rt` (real: dca.supervisor.net over dca.core; tests:
-- dca.supervisor.memory, in memory). The supervisor owns its group's children and nothing else: its leaves'
-- events and its child supervisors' outcomes come to it only, and it reports to its parent only when its
-- expression ends (plus progress/log lines when the parent asked for them).
--
--   local sup = require("dca.supervisor").new(spec, rt, opts)   -- spec: dca.supervisor.spec
--     opts: progress, timeouts, hosts, placement (handed to child supervisors; the runtime places the leaves),
--     and the hook console(sup) --> the console that answers `repl` and
--     `complete` requests (dca.supervisor.console.hook; none: those requests are refused). The engine requires
--     neither dca.core nor the console: its runtime and its hooks come from whoever creates it.
--   sup:configure(cb)         -- start children inactive, connect, cb(true) | cb(nil, reason)  (start+connect)
--   sup:run(init)             -- runs the expression; the outcome goes to rt.report{type="done"|"aborted"}
--   sup:abort(cb, reason)     -- aborts the running expression (LIFO), cb() once every stop is acknowledged;
--                             --   with a reason (a person's abort) the group's ABORTED goes up
--   sup:shutdown(cb)          -- aborts, then stops every child LIFO (processes gone), cb()
--   sup:restart(path, cb)     -- a group below: its expression again; a leaf below: a fresh process of it, wired
--                             --   and running as before while the rest runs (sup:restart_leaf(name, cb) in the
--                             --   leaf's own group). cb(true) | cb(nil, reason)
--   sup:restart_host(ch, fault)  -- hook (failover): the host a child restarts on after `fault` (nil: its own)
--   sup:policy_status()       -- the group's supervision policy and its budget used (nil without a policy)
-- With spec.supervision, faults of its children are restarted by the policy (section "supervision policy").
--   sup:handle(msg, reply)    -- a request from the parent (configure/run/abort/shutdown/node/tree/...)
--   sup:child_message(name, msg)  -- an event from a child (leaf node: done/aborted; child DCAS: done/aborted/log/
--                                 --   restarted {path}: a leaf below was restarted, its connections made again)
--   sup:child_exit(name, reason, lost)  -- a child's process exited (Executer) or, `lost` true, its channel,
--                             --   host or supervisor was lost (the policy's `lost` fault; reason: for display)
--   sup:children_exit(names, reason, lost)  -- several at once (the leaves of one shared node)
--
-- The runtime:
--   rt.spawn(child, cb)       -- child = a spec child (leaf or group); cb(handle) | cb(nil, reason). A handle
--                             --   has request(msg, timeout_s, cb(reply|nil, err)), send(msg), kill(signal, cb)
--                             --   (cb(true) once the process has exited, cb(nil, reason) if it outlived
--                             --   SIGKILL), and optionally lost() (stop reporting its exit: it was declared lost).
--                             --   A group's handle is a configured-to-be child DCAS: send it {type="configure"}.
--   rt.defer(fn)              -- fn from the loop, soon
--   rt.after(s, fn)           --> timer with cancel()
--   rt.every(s, fn)           --> periodic timer with cancel() (only with rt.heartbeat)
--   rt.heartbeat()            --> period, silence (optional: child supervisors are pinged, lost when silent)
--   rt.reap(group_spec)       -- optional: kills what a lost child supervisor had started (by path)
--   rt.world(msg, timeout_s, cb(reply|nil, err, missing)) -- a request to the robot process `world`
--                             --   (missing = true when no world is registered)
--   rt.types()                -- optional: the controller manifests (default: none; the network runtime's
--                             --   are dca.core.types())
--   rt.report(msg)            -- to the parent ({type="done", value=}, {type="aborted", path=, reason=}, log)
--   rt.log(line)              -- a line for this process's own output
--   rt.now()                  --> seconds
--   rt.on_sim_time()          --> optional: true when the events carry simulated time (lock-step): a supervision
--                             --   policy's restart window then counts in it
-- State lives in the object (a plain table); the methods live in M.Sup, which a reload of this module
-- updates in place, so running supervisors pick up new code and keep their state.
local algebra = require "dca.algebra"
local spec_mod = require "dca.supervisor.spec"
local policy = require "dca.supervisor.policy"
local failover = require "dca.supervisor.failover"
local taps = require "dca.supervisor.taps"

local previous = package.loaded["dca.supervisor"]
local M = type(previous) == "table" and previous or {}

local ipairs, pairs, type, tostring, sformat, select, tonumber = ipairs, pairs, type, tostring, string.format, select, tonumber
local concat = table.concat

--- Timeouts (seconds) of each wait of the start protocol; any of them may be overridden per supervisor.
M.timeouts = M.timeouts or { spawn = 10, configure = 30, connect = 5, stop = 5, request = 5 }
M.timeouts.shutdown = M.timeouts.shutdown or 30   -- a child group's whole subtree gone (each exit bounded)

M.Sup = M.Sup or {}
local Sup = M.Sup
Sup.__index = Sup

local LOG_KEEP = 500

local function show(v)
  if v == nil then return "nil" end
  if type(v) == "string" then return sformat("%q", v) end
  if type(v) ~= "table" then return tostring(v) end
  local parts, n = {}, 0
  for k, x in pairs(v) do
    n = n + 1
    if n > 8 then parts[#parts + 1] = "..." break end
    if k ~= "n" then parts[#parts + 1] = (type(k) == "number" and "" or tostring(k) .. "=") .. show(x) end
  end
  return "{" .. concat(parts, ", ") .. "}"
end
M.show = show

--- A new supervisor for the group `spec` on the runtime `rt`.
--- opts: { timeouts = {...}, progress = bool (send progress lines up), hosts = { name = daemon address } }.
function M.new(spec, rt, opts)
  opts = opts or {}
  local self = setmetatable({
    spec = spec, path = spec.path, rt = rt,
    timeouts = setmetatable(opts.timeouts or {}, { __index = M.timeouts }),
    timeouts_override = opts.timeouts,     -- handed down to child supervisors
    placement = opts.placement,            -- where leaves run (dca.supervisor.net), handed down too
    hosts = opts.hosts,                    -- host name -> daemon address (handed down too)
    progress = opts.progress or false,     -- send progress/transition lines up (dca run asked for them)
    console = opts.console,                -- hook: console(sup) --> the console of `repl` requests
    children = {},                         -- name -> child state (below)
    order = {},                            -- names in the order their processes started (LIFO teardown)
    state = "new",                         -- new | starting | configured | running | done | aborted | failed | stopped
    run = nil, expr = nil, cause = nil, outcome = nil,
    logbuf = {}, pending_expr = nil,
    stats = { leaf_events = 0, group_events = 0 },
  }, Sup)
  for _, c in ipairs(spec.children) do
    self.children[c.name] = { spec = c, name = c.name, path = c.path, kind = c.kind, host = c.host,
                              state = "new", handle = nil, manual = false }
  end
  if spec.expr then
    local e, err, info = algebra.parse(spec.expr)
    if not e then
      self.expr_error = sformat("%s:%d:%d: %s", spec.file or "?", (spec.expr_line or 1) + (info and info.line or 1) - 1,
        (info and info.line or 1) == 1 and (spec.expr_col or 1) + (info and info.col or 1) - 1 or (info and info.col or 1),
        info and info.msg or err)
    else
      self.expr = e
      for _, name in ipairs(e.names) do
        if not self.children[name] then
          self.expr_error = sformat("%s:%d:%d: %s: unknown process '%s'", spec.file or "?", spec.expr_line or 0,
            spec.expr_col or 0, spec.path, name)
        end
      end
    end
  end
  return self
end

---------------------------------------------------------------------------------------------- logging

function Sup:log(fmt, ...)
  local line = select("#", ...) > 0 and sformat(fmt, ...) or fmt
  -- a ring of the last LOG_KEEP lines: logbuf[1 + (k - 1) % LOG_KEEP] holds line number k
  local k = (self.logn or 0) + 1
  self.logn = k
  self.logbuf[1 + (k - 1) % LOG_KEEP] = sformat("%.3f %s", self.rt.now(), line)
  return line
end

--- The last n log lines of this supervisor, oldest first.
function Sup:recent(n)
  local total = self.logn or 0
  n = math.min(n or 20, total, LOG_KEEP)
  local out = {}
  for k = total - n + 1, total do out[#out + 1] = self.logbuf[1 + (k - 1) % LOG_KEEP] end
  return out
end

-- A line for the person watching (`dca run`): to the parent when asked for, else to this process's output.
-- A line said while an event is handled carries the event's time on its node's clock (`at`, seconds: the
-- `now` of a leaf's done/aborted, handed down with `run` and up with a group's outcome) to `dca run`, which
-- stamps lines with it in simulated time.
function Sup:say(fmt, ...)
  local line = self:log(fmt, ...)
  if self.progress then self.rt.report({ type = "log", line = line, at = self.event_at or self.recovery_at })
  elseif self.rt.log then self.rt.log(line) end
end

local function now_ns(at) return at and math.floor(at * 1e9 + 0.5) or nil end

---------------------------------------------------------------------------------------------- start

local function countdown(n, done)
  if n == 0 then done() return function() end end
  return function()
    n = n - 1
    if n == 0 then done() end
  end
end

-- Phase 1: every child process started (inactive); groups configured (their subtree up and wired).
-- A failure is reported (cb(nil, reason), the first one) only once every spawn in flight has answered or
-- timed out, so that the shutdown which follows finds every process that was started; a handle that still
-- arrives after that (a spawn answered after its timeout) is killed on arrival.
function Sup:_start_children(cb)
  local failed, reason, finished = false, nil, false
  local names = {}
  for _, c in ipairs(self.spec.children) do names[#names + 1] = c.name end
  local outstanding = #names
  local function settle_one()
    outstanding = outstanding - 1
    if outstanding == 0 and not finished then
      finished = true
      if failed then cb(nil, reason) else cb(true) end
    end
  end
  local function fail(why)
    if not failed then failed, reason = true, why end
  end
  if outstanding == 0 then finished = true cb(true) return end
  for _, name in ipairs(names) do
    local ch = self.children[name]
    ch.state = "starting"
    local timer, answered = nil, false
    timer = self.rt.after(self.timeouts.spawn, function()
      if ch.state == "starting" and not answered then
        answered = true
        fail(sformat("%s (%s on host %s) did not start within %gs", ch.path, ch.kind == "group" and "supervisor"
          or "node", tostring(ch.host), self.timeouts.spawn))
        settle_one()
      end
    end)
    self.rt.spawn(ch.spec, function(handle, err)
      if timer then timer:cancel() end
      if answered then
        -- too late: the start already failed; whatever started is stopped at once
        if handle then handle.kill("KILL") end
        return
      end
      if not handle then
        answered = true
        ch.state = "failed"
        fail(sformat("%s: could not start on host %s: %s", ch.path, tostring(ch.host), tostring(err)))
        settle_one()
        return
      end
      ch.handle = handle
      self.order[#self.order + 1] = name
      if ch.kind == "leaf" or failed then
        -- (a group is not configured once the start has failed: the shutdown stops its supervisor)
        answered = true
        ch.state = "inactive"
        settle_one()
        return
      end
      ch.state = "configuring"
      handle.request(self:_configure_msg(ch), self.timeouts.configure, function(reply, rerr, error_reply)
          if answered then return end
          answered = true
          if not reply or reply.type == "error" then
            ch.state = "failed"
            -- an error reply carries the child's own reason (naming what failed below it); else no answer
            fail(reply and reply.reason or (error_reply and rerr) or
              sformat("%s (supervisor on host %s) did not answer: %s", ch.path, tostring(ch.host), tostring(rerr)))
          else
            ch.state = "inactive"
            self:_watch(name, handle)
          end
          settle_one()
        end)
    end)
  end
end

-- What a child supervisor is configured with: its group's spec and what this one hands down.
function Sup:_configure_msg(ch)
  return { type = "configure", spec = ch.spec.spec, progress = self.progress, hosts = self.hosts,
           timeouts = self.timeouts_override, placement = self.placement }
end

-- Heartbeat of a child supervisor: pinged every rt.heartbeat() period; no answer within the silence bound
-- (a stopped or wedged process keeps its socket open) makes it lost: ABORTED at this group naming its host.
-- Only runtimes with a heartbeat (the real one; the fake when asked) do this.
function Sup:_watch(name, handle)
  if not self.rt.heartbeat then return end
  local period, silence = self.rt.heartbeat()
  local ch = self.children[name]
  local beat, busy
  beat = self.rt.every(period, function()
    if ch.handle ~= handle then beat:cancel() return end
    if busy then return end
    busy = true
    handle.request({ type = "ping" }, silence, function(r, err)
      busy = false
      if r or ch.handle ~= handle then return end
      beat:cancel()
      local reason = sformat("supervisor lost on host %s (no answer for %gs: %s)", tostring(ch.host), silence,
        tostring(err))
      -- it is ended for good (SIGKILL: a stopped process cannot stop itself) and so is what it started
      handle.kill("KILL")
      if handle.lost then handle.lost() end
      if self.rt.reap then self.rt.reap(ch.spec) end
      self:child_exit(name, reason, true)
    end)
  end)
end

-- Sends a message to the node of leaf `leaf_path`, directly when it is ours, else through the child DCAS
-- whose subtree holds it. cb(reply, err).
function Sup:to_leaf(leaf_path, msg, timeout, cb)
  local c = spec_mod.route(self.spec, leaf_path)
  local ch = c and self.children[c.name]
  if not ch or not ch.handle then
    if cb then cb(nil, sformat("%s: no route to %s", self.path, leaf_path)) end
    return
  end
  -- always a request: its answer (or its failure, logged) says the command arrived
  cb = cb or function(reply, err)
    if not reply or reply.type == "error" then
      self:log("%s: %s to %s: %s", self.path, tostring(msg.type), leaf_path, reply and reply.reason or tostring(err))
    end
  end
  timeout = timeout or self.timeouts.request
  M.note_tap(ch, leaf_path, msg)
  if ch.kind == "leaf" then
    ch.handle.request(msg, timeout, cb)
  else
    ch.handle.request({ type = "node", leaf = leaf_path, msg = msg }, timeout, cb)
  end
end

-- A tap's link to a leaf of child `ch` (the leaf itself, or one in its subtree: dca.supervisor.taps: a stamped
-- connect, the activation of its set "tap:..."), remembered on the child so that a restart makes it again on the
-- new process (or on every new process of a restarted subtree), inside the restart (Sup:_retap: so in simulated
-- time at the restart's tick, before the barrier ends).
function M.note_tap(ch, leaf, msg)
  local set = type(msg.set) == "string" and msg.set or ""
  local tap = (msg.type == "connect" and msg.stamped == true) or
    ((msg.type == "activate" or msg.type == "deactivate") and set:sub(1, 4) == "tap:")
  if not tap then return end
  ch.taps = ch.taps or { order = {} }
  local key = leaf .. " " .. set
  local t = ch.taps[key]
  if not t then t = { leaf = leaf, set = set, to = {}, connect = {} } ch.taps[key] = t ch.taps.order[#ch.taps.order + 1] = key end
  if msg.type ~= "connect" then t.active = msg.type == "activate" return end
  -- one link per destination (the run's own tap point, the world's recording, an attached monitor's)
  local to = tostring(msg.to)
  if not t.connect[to] then t.to[#t.to + 1] = to end
  t.connect[to] = msg
end

-- A tap's destination `to` forgotten (its link failed on a restart: a closed monitor's tap point is not waited for
-- again at the next one).
function M.forget_tap(t, to)
  if not (to and t.connect[to]) then return end
  t.connect[to] = nil
  for i, x in ipairs(t.to) do if x == to then table.remove(t.to, i) break end end
end

-- The taps remembered for child `ch` made again (each destination's link connected, then the set activated if it
-- was), k() after; a link that fails (e.g. its tap point is gone) is logged and forgotten, the others and the
-- restart go on.
function Sup:_retap(ch, k)
  local order = ch.taps and ch.taps.order or {}
  local left = #order
  if left == 0 then k() return end
  local function one() left = left - 1 if left == 0 then k() end end
  for _, key in ipairs(order) do
    local t = ch.taps[key]
    local links = #t.to
    local function connected(r, err, to)
      if not r or r.type == "error" then
        self:log("%s: tap %s of restarted %s: %s", self.path, t.set, t.leaf, r and r.reason or tostring(err))
        M.forget_tap(t, to)
      end
      links = links - 1
      if links > 0 then return end
      if t.active then self:to_leaf(t.leaf, { type = "activate", set = t.set }, self.timeouts.connect, one)
      else one() end
    end
    if links == 0 then links = 1 connected({ type = "ok" }) end
    for _, to in ipairs({ table.unpack(t.to) }) do
      self:to_leaf(t.leaf, t.connect[to], self.timeouts.connect, function(r, err) connected(r, err, to) end)
    end
  end
end

-- Phase 2: this group's own connections, resolved to leaf ports, created inactive at each source node.
function Sup:_connect(cb)
  local wires, errs = spec_mod.wiring(self.spec)
  if not wires then cb(nil, concat(errs, "; ")) return end
  self.wires = wires
  self.set_sources = {}
  for _, w in ipairs(wires) do
    local s = self.set_sources[w.set]
    if not s then s = {} self.set_sources[w.set] = s end
    if not s[w.src] then s[w.src] = true s[#s + 1] = w.src end
  end
  self:_connect_wires(wires, cb)
end

-- Makes the connections `list` (spec_mod.wiring's) at once; `after(w, k)`, if given, runs once `w` is made and
-- calls k(true) | k(nil, reason). cb(true) once every one is made | cb(nil, the first reason).
function Sup:_connect_wires(list, cb, after)
  local failed = false
  local tick = countdown(#list, function() if not failed then cb(true) end end)
  local function step(ok, err)
    if failed then return end
    if not ok then failed = true cb(nil, err) return end
    tick()
  end
  for _, w in ipairs(list) do
    self:_connect_wire(w, function(ok, err)
      if ok and after then after(w, step) else step(ok, err) end
    end)
  end
end

-- One connection `w` (from spec_mod.wiring) made at its source node. cb(true) | cb(nil, reason naming it)
function Sup:_connect_wire(w, cb)
  self:to_leaf(w.src, { type = "connect", out = w.out, to = w.dst, ["in"] = w["in"], set = w.set, mode = "push" },
    self.timeouts.connect, function(reply, err)
      if reply and reply.type ~= "error" then cb(true) return end
      cb(nil, sformat("%s: connecting %s.%s -> %s.%s (set %s): %s", self.path, w.src, w.out, w.dst, w["in"], w.set,
        reply and reply.reason or tostring(err)))
    end)
end

--- The device ports of the group's own leaves, in declaration order:
--- { { leaf = path, type = T, port = name, signal = "arm.q", dir = "in" | "out" }, ... }
function M.device_ports(spec, types)
  local list = {}
  for _, c in ipairs(spec.children) do
    local t = c.kind == "leaf" and types[c.type]
    if t then
      for _, dir in ipairs({ "inputs", "outputs" }) do
        for _, p in ipairs(t[dir] or {}) do
          if p.device and p.device ~= "" then
            list[#list + 1] = { leaf = c.path, type = c.type, port = p.name, signal = p.device,
                                dir = dir == "inputs" and "in" or "out" }
          end
        end
      end
    end
  end
  return list
end

-- "main.door.xr4000 (XR4000Ctrl: Cmd -> base.cmd_vel, Odom <- base.pose)", one per leaf
local function describe_devices(ports)
  local by_leaf, order = {}, {}
  for _, p in ipairs(ports) do
    local l = by_leaf[p.leaf]
    if not l then l = { type = p.type, parts = {} } by_leaf[p.leaf] = l order[#order + 1] = p.leaf end
    l.parts[#l.parts + 1] = p.dir == "in" and (p.port .. " <- " .. p.signal) or (p.port .. " -> " .. p.signal)
  end
  local out = {}
  for _, leaf in ipairs(order) do
    out[#out + 1] = sformat("%s (%s: %s)", leaf, by_leaf[leaf].type, concat(by_leaf[leaf].parts, ", "))
  end
  return concat(out, "; ")
end

-- Phase 2b: device ports of this group's leaves wired to the robot process `world` (ARCHITECTURE.md, "The
-- robot: device ports"): an input's signal world -> leaf, an output leaf -> world, in the set
-- "<leaf path>:device", activated at once and for good (the algebra never touches these sets).
-- With `only` (a leaf path: a restarted leaf), that leaf's device ports only.
function Sup:_wire_devices(cb, only)
  local types = self.rt.types and self.rt.types() or {}
  local ports = M.device_ports(self.spec, types)
  if only then
    local mine = {}
    for _, p in ipairs(ports) do if p.leaf == only then mine[#mine + 1] = p end end
    ports = mine
  else
    self.device_ports = ports
  end
  if #ports == 0 then cb(true) return end
  local function no_world(err)
    return sformat("%s: no world for the device ports of %s (start it with `dca run --sim WORLD`, or a robot "
      .. "driver registered as `world`): %s", self.path, describe_devices(ports), tostring(err))
  end
  if not self.rt.world then cb(nil, no_world("this runtime reaches no world")) return end
  local failed = false
  local activated = {}
  local tick = countdown(#ports, function() if not failed then cb(true) end end)
  local function fail(p, what, reply, err, missing)
    if failed then return end
    failed = true
    if missing then cb(nil, no_world(err)) return end
    cb(nil, sformat("%s: %s device port %s.%s (%s): %s", self.path, what, p.leaf, p.port, p.signal,
      reply and reply.reason or tostring(err)))
  end
  for _, p in ipairs(ports) do
    local set = p.leaf .. ":device"
    -- the source of the connection: the world for an input, the leaf for an output
    local function at_source(msg, k)
      if p.dir == "in" then self.rt.world(msg, self.timeouts.connect, k)
      else self:to_leaf(p.leaf, msg, self.timeouts.connect, k) end
    end
    -- a queue of one: a device port holds the robot's latest reading or command (the set is active while
    -- the leaf waits inactive: older samples would pile up and be read stale when it runs)
    local conn = p.dir == "in"
      and { type = "connect", out = p.signal, to = p.leaf, ["in"] = p.port, set = set, mode = "push", queue = 1 }
      or { type = "connect", out = p.port, to = "world", ["in"] = p.signal, set = set, mode = "push", queue = 1 }
    at_source(conn, function(reply, err, missing)
      if failed then return end
      if not reply or reply.type == "error" then fail(p, "connecting", reply, err, missing) return end
      local key = p.dir .. " " .. set
      if activated[key] then tick() return end
      activated[key] = true
      at_source({ type = "activate", set = set }, function(r2, e2)
        if failed then return end
        if not r2 or r2.type == "error" then fail(p, "activating", r2, e2) return end
        tick()
      end)
    end)
  end
end

--- Start protocol below this group: children started inactive, then connected. cb(true) | cb(nil, reason).
function Sup:configure(cb)
  if self.expr_error then self.state = "failed" cb(nil, self.expr_error) return end
  self.state = "starting"
  self:say("%s: starting %d processes", self.path, #self.spec.children)
  self:_start_children(function(ok, err)
    if not ok then self.state = "failed" cb(nil, err) return end
    self:say("%s: started", self.path)
    self:_connect(function(ok2, err2)
      if not ok2 then self.state = "failed" cb(nil, err2) return end
      self:say("%s: connected (%d connections)", self.path, #self.wires)
      self:_wire_devices(function(ok3, err3)
        if not ok3 then self.state = "failed" cb(nil, err3) return end
        if #self.device_ports > 0 then
          self:say("%s: %d device ports wired to the world", self.path, #self.device_ports)
        end
        local function configured()
          self.state = "configured"
          self:say("%s: configured", self.path)
          cb(true)
        end
        -- on simulated time, this supervisor takes part in the clock's barrier (dca.supervisor.net)
        if not self.rt.join_clock then configured() return end
        self.rt.join_clock(self.path, function(ok4, err4)
          if not ok4 then self.state = "failed" cb(nil, err4) return end
          configured()
        end)
      end)
    end)
  end)
end

---------------------------------------------------------------------------------------------- run

function Sup:_commands()
  local sup = self
  return {
    start = function(name, init) sup:_start_child(name, init) end,
    abort = function(name) sup:_abort_child(name) end,
    activate = function(name, label) sup:_set(name, label, "activate") end,
    deactivate = function(name, label) sup:_set(name, label, "deactivate") end,
    is_running = function(name)
      local ch = sup.children[name]
      return ch ~= nil and ch.manual
    end,
    log = function(line) sup:log("%s: %s", sup.path, line) end,
  }
end

function Sup:_set(name, label, what)
  local id = spec_mod.set_id(self.path, name, label)
  local srcs = self.set_sources and self.set_sources[id]
  if not srcs then return end
  -- kept so that a restarted source's sets are activated again (Sup:_rewire)
  self.active_sets = self.active_sets or {}
  self.active_sets[id] = what == "activate" or nil
  for _, src in ipairs(srcs) do self:to_leaf(src, { type = what, set = id }) end
end

-- An event into the expression, from the loop (never from inside a command).
function Sup:_feed(name, kind, value)
  local run = self.run
  if not run then return false end
  local taken = run:event(name, kind, value)
  self:_check_outcome()
  return taken
end

function Sup:_fail_later(name, reason)
  self.rt.defer(function()
    local ch = self.children[name]
    if self.run and self.run:is_running(name) then
      self.cause = self.cause or { path = ch.path, reason = reason }
      if self:_feed(name, "error", reason) then
        self.cause = self.cause or { path = ch.path, reason = reason }
      end
    end
  end)
end

function Sup:_start_child(name, init)
  local ch = self.children[name]
  if ch.policy_fault or ch.policy_restart then
    -- being restarted by the group's policy: it runs once its new process is up (Sup:_run_again)
    ch.init, ch.start_pending = init, true
    self:say("%s: running once restarted", ch.path)
    return
  end
  if not ch.handle or ch.state == "exited" or ch.state == "lost" then
    self:_fail_later(name, sformat("%s is not running (%s)", ch.path, ch.exit_reason or ch.state))
    return
  end
  ch.state = "running"
  ch.init = init                 -- a restarted leaf runs again with it (Sup:restart_leaf)
  ch.run_no = (ch.run_no or 0) + 1
  local run_no = ch.run_no
  self:say("%s: running", ch.path)
  local function check(reply, err)
    if (not reply or reply.type == "error") and ch.state == "running" and ch.run_no == run_no then
      -- a channel closed under a policy: the process's exit (or loss) follows and the policy takes it
      if not reply and self.spec.supervision and tostring(err):find("closed") then return end
      self:_fail_later(name, sformat("%s: %s", ch.path, reply and reply.reason or tostring(err)))
    end
  end
  -- while run_expr starts the expression, the answers to these runs are counted (run_expr's cb)
  local acks = self.run_acks
  if acks then acks.n = acks.n + 1 end
  local function ran(reply, err)
    check(reply, err)
    if acks then
      acks.n = acks.n - 1
      if acks.n == 0 and acks.cb then local f = acks.cb acks.cb = nil f() end
    end
  end
  if ch.kind == "leaf" then
    ch.handle.request({ type = "init" }, self.timeouts.request, check)
    ch.handle.request({ type = "run", init = init }, self.timeouts.request, ran)
  else
    -- a group answers when its whole started subtree has: bounded like a configure
    ch.handle.request({ type = "run", init = init, at = self.event_at }, self.timeouts.configure, ran)
  end
end

function Sup:_abort_child(name)
  local ch = self.children[name]
  ch.start_pending = nil
  -- a leaf whose process already ended (with others of its shared node: children_exit) has nothing to stop
  local dead = ch.state == "exited"
  if not dead then
    ch.state = "stopping"
    self:say("%s: aborting", ch.path)
  end
  local ack = self.abort_ack
  if ack then ack.n = ack.n + 1 end
  self.stops_pending = (self.stops_pending or 0) + 1
  local function done(reply, err)
    if ch.state == "stopping" then ch.state = "inactive" end
    if not reply or reply.type == "error" then
      self:log("%s: stop of %s: %s", self.path, ch.path, reply and reply.reason or tostring(err))
    end
    if not dead then self:say("%s: stopped", ch.path) end
    self.stops_pending = self.stops_pending - 1
    if self.stops_pending == 0 and self.event_t0 then
      -- preemption latency: the event that caused these aborts to the last abort acknowledged
      local st = self.stats
      st.preempt_n = (st.preempt_n or 0) + 1
      st.preempt = st.preempt or {}
      st.preempt[1 + (st.preempt_n - 1) % 1000] = self.rt.now() - self.event_t0
      self.event_t0 = nil
    end
    if self.stops_pending == 0 and self.held_report then
      local m = self.held_report
      self.held_report = nil
      self.rt.report(m)
    end
    if ack then
      ack.n = ack.n - 1
      if ack.n == 0 and ack.cb then local f = ack.cb ack.cb = nil f() end
    end
  end
  if not ch.handle or dead then done({ type = "ok" }) return end
  ch.handle.request({ type = ch.kind == "leaf" and "stop" or "abort" }, self.timeouts.stop, done)
end

-- The outcome goes up only once every stop it caused is acknowledged: when a group reports, none of its
-- processes runs (SEMANTICS.md §5: a composite never half-finishes).
function Sup:_report(msg)
  if (self.stops_pending or 0) > 0 then self.held_report = msg else self.rt.report(msg) end
end

function Sup:_check_outcome()
  local run = self.run
  if not run or self.state ~= "running" then return end
  local st, v = run:status()
  if st == "done" then
    self.state = "done"
    self.outcome = { status = "done", value = v }
    self:say("%s: done %s", self.path, show(v))
    self:_report({ type = "done", value = v, now = now_ns(self.event_at) })
  elseif st == "aborted" then
    self.state = "aborted"
    local cause = self.cause or { path = self.path, reason = "aborted" }
    self.outcome = { status = "aborted", path = cause.path, reason = cause.reason }
    self:say("%s: aborted (%s: %s)", self.path, cause.path, cause.reason)
    self:_report({ type = "aborted", path = cause.path, reason = cause.reason, now = now_ns(self.event_at) })
  end
end

--- Runs this group's expression (the parent's "run"), with `init` bound for every leaf (dca.algebra).
--- `started(ok)`, if given, is called once every process the start of the expression ran (below this
--- group too) has answered its run (`dca run --sim` starts the simulated time then).
function Sup:run_expr(init, started)
  if self.state == "running" then
    if started then started(false) end
    return nil, self.path .. " is already running"
  end
  if not self.expr then
    -- a group without event actions runs nothing and is done at once
    self.state = "running"
    self.run = nil
    self.rt.defer(function()
      self.state = "done" self.outcome = { status = "done" }
      self.rt.report({ type = "done" })
    end)
    if started then started(true) end
    return true
  end
  if self.pending_expr then
    self.expr, self.pending_expr = self.pending_expr, nil
    self:say("%s: new event actions in effect", self.path)
  end
  self.cause, self.outcome, self.escalated = nil, nil, nil
  -- (a run after an escalation: no child still waits for a restart that will not come)
  for _, ch in pairs(self.children) do ch.policy_fault, ch.start_pending = nil, nil end
  self.state = "running"
  self.last_init = init
  self.run = algebra.new(self.expr, self:_commands())
  local acks = { n = 1, cb = started and function() started(true) end }
  self.run_acks = acks
  self.run:start(init)
  self.run_acks = nil
  acks.n = acks.n - 1
  if acks.n == 0 and acks.cb then local f = acks.cb acks.cb = nil f() end
  self:_check_outcome()
  return true
end

--- Aborts the running expression (one LIFO abort); cb() once every abort is acknowledged. With `reason`
--- (the group aborted by a person: the REPL's abort(), the monitor), the group's ABORTED outcome goes up as
--- any outcome, so the parent's algebra (or, at the root, `dca run`) sees the group end; without it (the
--- parent's own abort, a restart, a shutdown) nothing is reported.
function Sup:abort(cb, reason)
  if not self.run or self.state ~= "running" then if cb then cb() end return end
  local ack = { n = 1, cb = cb }
  self.abort_ack = ack
  self.state = "aborting"
  self.run:abort()
  self.abort_ack = nil
  self.state = "aborted"
  self.outcome = { status = "aborted", path = self.path, reason = reason or "aborted by its parent" }
  self:say("%s: aborted", self.path)
  if reason then self:_report({ type = "aborted", path = self.path, reason = reason, now = now_ns(self.event_at) }) end
  ack.n = ack.n - 1
  if ack.n == 0 and ack.cb then local f = ack.cb ack.cb = nil f() end
end

---------------------------------------------------------------------------------------------- events

--- A message from child `name`: a leaf node's done/aborted event, or a child DCAS's done/aborted/log.
function Sup:child_message(name, msg)
  local ch = self.children[name]
  if not ch then return end
  local t = msg.type
  if t == "log" then
    if self.progress then self.rt.report(msg) end
    self:log("%s", msg.line)
    return
  end
  if t == "restarted" then self:_leaf_restarted(msg.path) return end
  if ch.restarting and (t == "done" or t == "aborted") then
    -- the old process's last word, sent before its stop: the algebra sees nothing of a restart
    self:log("%s: %s from the process being restarted ignored", ch.path, t)
    return
  end
  if ch.kind == "leaf" then self.stats.leaf_events = self.stats.leaf_events + 1
  else self.stats.group_events = self.stats.group_events + 1 end
  local saved_at = self.event_at
  if tonumber(msg.now) then self.event_at = tonumber(msg.now) / 1e9 end
  local t0 = self.rt.now()
  local pending0 = self.stops_pending or 0
  if t == "done" then
    local taken = self.run and self.run:is_running(name)
    if taken then
      ch.state = "done"
      if ch.kind == "leaf" then self:say("%s: done %s", ch.path, show(msg.value)) end
    end
    if not self:_feed(name, "done", msg.value) and not taken then
      self:log("%s: stale done from %s ignored", self.path, ch.path)
    end
  elseif t == "aborted" then
    self:_child_aborted(name, ch, msg)
  end
  if t == "overflow" and self:_is_device_input(ch.path, msg.port) then
    -- a device input holds the robot's latest sample (a queue of one): the older one dropped is expected
    self.event_at = saved_at
    return
  end
  local restarting = t == "broken" and self:_restarting_peer(msg.peer)
  if t == "broken" and (self.shutdown_waiters or self.state == "stopping" or self.state == "stopped"
                        or ch.state ~= "running" or restarting) then
    -- the tree is being stopped (the process at the other end was stopped first, LIFO), this leaf does not
    -- run, or the other end is being restarted (its connections are made again): kept in the log only
    self:log("%s: broken %s%s: %s (%s)", ch.path, tostring(msg.port), msg.peer and (" <-> " .. tostring(msg.peer)) or "",
      tostring(msg.reason), self.shutdown_waiters and "while stopping" or restarting and ("while " .. restarting ..
      " restarts") or ("while " .. tostring(ch.state)))
  elseif t == "broken" or t == "overflow" then
    -- a data connection of this leaf broke or overflowed: worth a line, not an event of the algebra (the
    -- process at the other end, if it died, is reported by its own owner)
    self:say("%s: %s %s%s: %s", ch.path, t, tostring(msg.port), msg.peer and (" <-> " .. tostring(msg.peer)) or "",
      tostring(msg.reason))
  end
  if pending0 == 0 and (self.stops_pending or 0) > 0 then self.event_t0 = t0 end
  self.event_at = saved_at
end

-- A child's ABORTED (a leaf's Abort, a sub-group's outcome): restarted by the group's policy when it covers the
-- fault (the algebra sees nothing), else an event of the algebra.
function Sup:_child_aborted(name, ch, msg)
  local path, reason = msg.path or ch.path, msg.reason or "aborted"
  local taken = self.run and self.run:is_running(name)
  local how = ch.kind == "group" and msg.escalated and "escalated" or "aborted"
  local kind = policy.kind(how)
  if taken and self:_policy_takes(kind) then
    ch.state = "aborted"
    self:say("%s: %s: %s", ch.path, how, reason)
    self:_fault({ name }, how, kind, reason, { path = path, reason = reason })
    return
  end
  if taken then
    ch.state = "aborted"
    self:say("%s: aborted: %s", ch.path, reason)
    self.cause = self.cause or { path = path, reason = reason }
  end
  if not self:_feed(name, "aborted", reason) and not taken then
    self:log("%s: stale aborted from %s ignored", self.path, ch.path)
  end
end

function Sup:_is_device_input(leaf, port)
  for _, p in ipairs(self.device_ports or {}) do
    if p.leaf == leaf and p.port == port and p.dir == "in" then return true end
  end
  return false
end

--- Child `name`'s process exited (the Executer's signal) or (`lost` true) its channel, supervisor or host was lost.
function Sup:child_exit(name, reason, lost)
  self:children_exit({ name }, reason, lost)
end

--- Several children's processes ended at once (the leaves of one shared node, dca.supervisor.net): each is
--- marked ended first, then the algebra hears of those that ran, in the order given, so none of them is
--- stopped as a sibling of another.
function Sup:children_exit(names, reason, lost)
  local ran, faulted, kind = {}, {}, policy.kind("exit", lost)
  for _, name in ipairs(names) do
    local ch = self.children[name]
    if not ch or ch.state == "exited" or ch.state == "lost" or ch.state == "gone" then goto next end
    if ch.restarting then
      -- the old process of a leaf being restarted: its exit was asked for, not a crash
      self:log("%s: old process exited (%s)", ch.path, tostring(reason))
      goto next
    end
    if self:_policy_takes(kind) then faulted[#faulted + 1] = name
    elseif self.run and self.run:is_running(name) then ran[#ran + 1] = name end
    ch.state = ch.kind == "leaf" and "exited" or "lost"
    ch.exit_reason = reason
    ch.handle = nil
    self:say("%s: %s: %s", ch.path, ch.kind == "leaf" and "exited" or "lost", reason)
    ::next::
  end
  -- the group's supervision policy restarts these (one fault, whichever number of leaves it ended)
  if #faulted > 0 then self:_fault(faulted, "exit", kind, reason) end
  for _, name in ipairs(ran) do
    self.cause = self.cause or { path = self.children[name].path, reason = reason }
    self:_feed(name, "error", reason)
  end
  local first = self.children[names[1]]
  if self.starting_cb and first then
    local f = self.starting_cb
    self.starting_cb = nil
    f(nil, sformat("%s: %s", first.path, reason))
  end
end

---------------------------------------------------------------------------------------------- restart of a leaf
-- A leaf is restarted by its own group: the old process is stopped (Stop(): actuators at zero) and ended, a
-- fresh one of the same instance (type, arguments, host; its `config("key")` arguments read again) is started,
-- the connections of the leaf are made again in both directions by every group that owns one (this one, then
-- each ancestor as the `restarted {path}` event goes up), its active sets are activated again, and it is
-- run again with its `init` if it was running. The algebra sees nothing: no event of the old process counts,
-- and its exit is not a crash. Other processes never stop.

local RESTARTABLE = { inactive = true, running = true, done = true, aborted = true }

--- Starts the leaf `name` of this group anew (see above). cb(true) once it is started, wired and (if it was
--- running) running again; cb(nil, reason) if it cannot be restarted (the leaf untouched) or if the restart
--- failed (the leaf then ended ABORTED with the reason, as for any abort).
function Sup:restart_leaf(name, cb)
  local ch = self.children[name]
  if not ch or ch.kind ~= "leaf" then cb(nil, sformat("%s has no leaf '%s'", self.path, tostring(name))) return end
  if ch.restarting then cb(nil, ch.path .. " is already being restarted") return end
  if not ch.handle or not RESTARTABLE[ch.state] then
    cb(nil, sformat("%s is not running (%s)", ch.path, ch.exit_reason or ch.state))
    return
  end
  local was_running = ch.state == "running" and self.run ~= nil and self.run:is_running(name)
  local old = ch.handle
  ch.restarting, ch.state = true, "restarting"
  self:say("%s: restarting", ch.path)
  local function ended(ok, err)
    if not ok then self:_restart_failed(name, was_running, err, cb) return end
    ch.handle = nil
    if self:_stopping_all(ch) then ch.restarting = nil cb(nil, ch.path .. ": stopped while restarting") return end
    self:_respawn(name, was_running, cb)
  end
  if was_running then
    old.request({ type = "stop" }, self.timeouts.stop, function(r, err)
      if not r or r.type == "error" then self:log("%s: stop of %s: %s", self.path, ch.path, r and r.reason or tostring(err)) end
      old.kill("TERM", ended)
    end)
  else
    old.kill("TERM", ended)
  end
end

-- The fresh process of leaf `name` (its old one ended), then _restore. A spawn failure fails the restart.
function Sup:_respawn(name, was_running, cb)
  local ch = self.children[name]
  local answered = false
  local timer = self.rt.after(self.timeouts.spawn, function()
    if answered then return end
    answered = true
    self:_restart_failed(name, was_running, sformat("%s (node on host %s) did not start within %gs", ch.path,
      tostring(ch.host), self.timeouts.spawn), cb)
  end)
  self.rt.spawn(ch.spec, function(handle, err)
    if timer then timer:cancel() end
    if answered then if handle then handle.kill("KILL") end return end
    answered = true
    if not handle then
      self:_restart_failed(name, was_running, sformat("%s: could not start on host %s: %s", ch.path,
        tostring(ch.host), tostring(err)), cb)
      return
    end
    if self:_stopping_all(ch) then
      ch.restarting = nil
      handle.kill("TERM")
      cb(nil, ch.path .. ": stopped while restarting")
      return
    end
    ch.handle, ch.restarting = handle, nil   -- from here on its exit is a crash like any other
    ch.state = "inactive"
    self:_restore(name, was_running, cb)
  end)
end

-- The new process of leaf `name` wired as its old one was (device ports, this group's connections, active
-- sets), its ancestors told (`restarted`), then run with its last `init` if it was running.
function Sup:_restore(name, was_running, cb)
  local ch = self.children[name]
  self:_wire_devices(function(ok, err)
    if not ok then self:_restart_failed(name, was_running, err, cb) return end
    self:_restart_tail(name, was_running, cb)
  end, ch.path)
end

-- The end of a restart of child `name` (a leaf's new process, or a sub-group's new supervisor with its subtree up):
-- this group's connections of it made again, the taps it remembers (of the leaf, or of every leaf of the subtree)
-- made again, the groups above told (`restarted`), then run again with its last `init` if it ran (unless its
-- group's expression aborted it meanwhile). cb(true) | the restart failed (Sup:_restart_failed)
function Sup:_restart_tail(name, was_running, cb)
  local ch = self.children[name]
  self:_rewire(ch.path, function(ok, err)
    if not ok then self:_restart_failed(name, was_running, err, cb) return end
    self:_retap(ch, function()
      self.rt.report({ type = "restarted", path = ch.path })
      self:_run_again(name, was_running)
      self:_restarted_line(ch)
      cb(true)
    end)
  end)
end

-- The group is being shut down (or `ch` was stopped for good): a restart in flight starts nothing more.
function Sup:_stopping_all(ch)
  return ch.state == "gone" or self.shutdown_waiters ~= nil or self.state == "stopping" or self.state == "stopped"
end

-- The restart of leaf `name` failed: whatever process it has is ended and, if it was running, it ends
-- ABORTED with the reason (its group's algebra decides what follows). cb(nil, reason)
function Sup:_restart_failed(name, was_running, reason, cb)
  local ch = self.children[name]
  ch.restarting = nil
  local h = ch.handle
  ch.handle, ch.state, ch.exit_reason = nil, "exited", reason
  if h then h.kill("KILL") end
  self:say("%s: restart failed: %s", ch.path, tostring(reason))
  -- (a restart by the group's policy escalates instead: Sup:_recover)
  if was_running and not ch.policy_restart and self.run and self.run:is_running(name) then
    self.cause = self.cause or { path = ch.path, reason = reason }
    self:_feed(name, "aborted", reason)
  end
  cb(nil, reason)
end

-- Whether the leaf `leaf` is `path` or lies below it (a restarted group's subtree).
local function under(leaf, path) return leaf == path or leaf:sub(1, #path + 1) == path .. "." end

--- Makes again this group's connections of leaf `path` (started anew), or of every leaf below the group `path`
--- (a subtree started anew): each one it is the source of at the new process, each one it is the destination of
--- at its source, whose endpoint replaces its link to the old process (host/endpoint); each activated at its
--- source when its set is active. cb(true) | cb(nil, reason)
function Sup:_rewire(path, cb)
  local list = {}
  for _, w in ipairs(self.wires or {}) do
    -- (a connection with a child still waiting for its own restart is made when that one is started)
    local other = under(w.src, path) and w.dst or w.src
    if (under(w.src, path) or under(w.dst, path)) and (under(other, path) or not self:_pending(other)) then
      list[#list + 1] = w
    end
  end
  self:_connect_wires(list, cb, function(w, k)
    -- the set active again at a new source: this one, or one started earlier by the same restart whose
    -- connection waited for this one
    if not (self.active_sets and self.active_sets[w.set]) or not (under(w.src, path) or self:_fresh(w.src)) then
      k(true)
      return
    end
    self:to_leaf(w.src, { type = "activate", set = w.set }, self.timeouts.connect, function(r, err)
      if r and r.type ~= "error" then k(true) return end
      k(nil, sformat("%s: activating %s at %s: %s", self.path, w.set, w.src, r and r.reason or tostring(err)))
    end)
  end)
end

-- Whether the process of leaf `leaf` is being started anew by this group's restart and is not up yet.
function Sup:_pending(leaf)
  local ch = self:_via(leaf)
  return ch ~= nil and ch.restarting == true and ch.handle == nil
end

-- Whether the process of leaf `leaf` was started anew by the restart in progress (Sup:_recover).
function Sup:_fresh(leaf)
  local ch = self:_via(leaf)
  return ch ~= nil and self.recovering ~= nil and self.recovering.started[ch.name] == true
end

-- A leaf below this group was restarted (the `restarted` event of a child group): this group's own
-- connections of it are made again, and the event goes on up.
function Sup:_leaf_restarted(path)
  if type(path) ~= "string" then return end
  self:_rewire(path, function(ok, err)
    if not ok then self:say("%s: reconnecting restarted %s: %s", self.path, path, tostring(err)) end
    self.rt.report({ type = "restarted", path = path })
  end)
end

---------------------------------------------------------------------------------------------- supervision policy
-- A group with a policy (spec.supervision, from its `supervision { }` section: dca.supervisor.policy) restarts
-- its children's faults of the kinds it names instead of telling the algebra: one_for_one the faulted child,
-- one_for_all every child, rest_for_one the faulted one and those after it in instantiation order. The children
-- are stopped in reverse start order (a running leaf: Stop(), actuators at zero, then its process ended; a
-- sub-group: its whole subtree shut down), then started again in order with the restart of a leaf's machinery
-- (fresh process, connections both ways by every group that owns one, active sets, Run with its last init; a
-- sub-group: a fresh supervisor configured with its spec, this group's connections of its leaves made again,
-- its expression run again if it ran). The algebra sees nothing. Past the restart intensity (N restarts within
-- T seconds, a sliding window on simulated time or rt.now(): Sup:_policy_now) the group escalates: it stops
-- its running children (LIFO, the algebra's abort) and ends ABORTED with a reason that says so and names the
-- fault that exceeded it, its outcome's path the first cause (a leaf); the parent's policy then applies to it
-- as a `crash` of that child.
-- Faults that arrive while a restart runs wait for it, in order.

--- Whether this group's policy restarts a fault of `kind` now (it runs, and is not being stopped).
function Sup:_policy_takes(kind)
  local pol = self.spec.supervision
  return pol ~= nil and pol.on ~= nil and pol.on[kind] == true and self.state == "running" and not self.escalated
    and self.shutdown_waiters == nil
end

--- A fault of the children `names` (all ended by it), `how` it ended ("exit" | "aborted" | "escalated"), its
--- kind and reason; `cause` = { path, reason } of the first cause (a sub-group's outcome names its leaf).
function Sup:_fault(names, how, kind, reason, cause)
  local first = self.children[names[1]]
  local f = { names = names, how = how, kind = kind, reason = reason, at = self.event_at,
              cause = cause or { path = first.path, reason = reason } }
  f.last = how == "exit" and sformat("%s %s", first.name, reason) or sformat("%s %s: %s", first.name, how, reason)
  for _, n in ipairs(names) do self.children[n].policy_fault = true end
  self.rt.defer(function() self:_recover(f) end)
end

--- The host a child restarts on after fault `f` (nil: the host it had): after its host was lost, the next of its
--- hosts (dca.supervisor.failover: a leaf's standby hosts, or its group's when it ran on the group's host; a
--- sub-group's host { } list), and a sub-group moves with the part of its subtree that ran on the lost host.
function Sup:restart_host(ch, f)
  if not f or f.kind ~= "lost" then return nil end
  local faulted = false
  for _, n in ipairs(f.names or {}) do faulted = faulted or n == ch.name end
  if not faulted then return nil end
  ch.failover_hosts = ch.failover_hosts or failover.hosts(ch.spec, self.spec)
  local to = failover.next_host(ch.failover_hosts, ch.host)
  if to and ch.kind == "group" then ch.spec.spec = failover.moved(ch.spec.spec, ch.host, to) end
  return to
end

-- The children a restart after fault `f` takes down and starts again, in start order (those with a process
-- or a fault: never started ones, or those already stopped for good, are left alone).
function Sup:_restart_plan(f)
  local order, faulted = {}, {}
  for _, c in ipairs(self.spec.children) do order[#order + 1] = c.name end
  for _, n in ipairs(f.names) do faulted[n] = true end
  local out = {}
  for _, name in ipairs(policy.plan(self.spec.supervision.strategy, order, faulted)) do
    local st = self.children[name].state
    if faulted[name] or not (st == "new" or st == "failed" or st == "gone" or st == "starting") then
      out[#out + 1] = name
    end
  end
  return out, faulted
end

--- Applies the policy to fault `f`: within the intensity, the strategy's restart; past it, escalation.
function Sup:_recover(f)
  if self.recovering then
    local q = self.recovering.queue
    q[#q + 1] = f
    return
  end
  if not self:_policy_takes(f.kind) then self:_unfault(f) return end
  local pol = self.spec.supervision
  local now = self:_policy_now(f.at)
  self.restart_times = policy.window(self.restart_times or {}, now, pol.within)
  if #self.restart_times >= pol.intensity then self:_escalate(f, policy.exceeded(pol, f.last)) return end
  self.restart_times[#self.restart_times + 1] = now
  self.restarts_total = (self.restarts_total or 0) + 1
  local plan, faulted = self:_restart_plan(f)
  local rec = { queue = {}, plan = plan, running = {}, started = {}, f = f }
  self.recovering, self.recovery_at = rec, f.at
  self.restarting_below = self.restarting_below or {}
  for _, name in ipairs(plan) do
    local ch = self.children[name]
    rec.running[name] = self.run ~= nil and self.run:is_running(name)
    ch.restarting, ch.policy_restart = true, true
    ch.restarts = (ch.restarts or 0) + 1
    if faulted[name] then
      ch.restart_note = sformat(" %d/%d in %g s", #self.restart_times, pol.intensity, pol.within)
    end
    self.restarting_below[ch.path] = (self.restarting_below[ch.path] or 0) + 1
  end
  self:say("%s: %s after %s: restarting %s (%d/%s)", self.path, pol.strategy, f.last, concat(plan, ", "),
    #self.restart_times, policy.budget(pol))
  local i = #plan + 1
  local function up(k)
    if k > #plan then self:_recovered(rec) return end
    rec.started[plan[k]] = true
    self:_bring_up(plan[k], rec.running[plan[k]], function(ok, err)
      if self.recovering ~= rec then return end
      if not ok and self.state ~= "running" then self:_recovered(rec) return end  -- stopped or aborted meanwhile
      if not ok then self:_escalate(f, sformat("restart of %s failed: %s", plan[k], tostring(err))) return end
      up(k + 1)
    end)
  end
  local function down()
    i = i - 1
    if i < 1 then up(1) return end
    self:_take_down(plan[i], rec.running[plan[i]], function()
      if self.recovering ~= rec then return end
      down()
    end)
  end
  down()
end

-- The restart after `rec` is over: the children's marks cleared, the faults that waited handled in order.
function Sup:_recovered(rec)
  self.recovering, self.recovery_at = nil, nil
  self:_unmark(rec)
  for _, f in ipairs(rec.queue) do self:_recover(f) end
end

-- The faulted children of `f` are no longer waiting for a restart (it was not made).
function Sup:_unfault(f)
  for _, n in ipairs(f.names) do
    local ch = self.children[n]
    ch.policy_fault, ch.start_pending = nil, nil
  end
end

function Sup:_unmark(rec)
  for _, name in ipairs(rec.plan) do
    local ch = self.children[name]
    ch.policy_restart, ch.restart_note, ch.policy_fault, ch.start_pending = nil, nil, nil, nil
    local path = ch.path
    local n = (self.restarting_below[path] or 1) - 1
    self.restarting_below[path] = n > 0 and n or nil
  end
end

-- Stops child `name` for a restart and ends its process (a sub-group: its subtree shut down first). cb()
function Sup:_take_down(name, was_running, cb)
  local ch = self.children[name]
  ch.state = "restarting"
  local old = ch.handle
  if not old then cb() return end
  self:say("%s: stopping to restart", ch.path)
  local function ended(ok, err)
    if not ok then self:log("%s: end of %s: %s", self.path, ch.path, tostring(err)) end
    if ch.handle == old then ch.handle = nil end
    cb()
  end
  local function kill() old.kill("TERM", ended) end
  if ch.kind == "group" then
    old.request({ type = "shutdown" }, self.timeouts.shutdown, kill)
  elseif was_running then
    old.request({ type = "stop" }, self.timeouts.stop, kill)
  else
    kill()
  end
end

-- Starts child `name` anew (after _take_down), on the host restart_host picks. cb(true) | cb(nil, reason)
function Sup:_bring_up(name, was_running, cb)
  local ch = self.children[name]
  if self:_stopping_all(ch) then ch.restarting = nil cb(nil, ch.path .. ": stopped while restarting") return end
  local host = self:restart_host(ch, self.recovering and self.recovering.f)
  if host and host ~= ch.host then
    self:say("%s: moves from host %s to host %s", ch.path, tostring(ch.host), tostring(host))
    ch.spec = setmetatable({ host = host }, { __index = ch.spec })
    ch.host = host
  end
  if ch.kind == "leaf" then self:_respawn(name, was_running, cb) return end
  self:_respawn_group(name, was_running, cb)
end

-- A fresh supervisor of the sub-group `name`, configured with its spec (its subtree started and wired), then the
-- tail every restart shares (Sup:_restart_tail).
function Sup:_respawn_group(name, was_running, cb)
  local ch = self.children[name]
  local answered = false
  local function failed(err)
    if answered then return end
    answered = true
    self:_restart_failed(name, was_running, err, cb)
  end
  local timer = self.rt.after(self.timeouts.spawn + self.timeouts.configure, function()
    failed(sformat("%s (supervisor on host %s) did not start within %gs", ch.path, tostring(ch.host),
      self.timeouts.spawn + self.timeouts.configure))
  end)
  self.rt.spawn(ch.spec, function(handle, err)
    if answered then if handle then handle.kill("KILL") end return end
    if not handle then timer:cancel() failed(sformat("%s: could not start on host %s: %s", ch.path,
      tostring(ch.host), tostring(err))) return end
    ch.handle = handle
    handle.request(self:_configure_msg(ch), self.timeouts.configure, function(reply, rerr)
      timer:cancel()
      if answered then return end
      if not reply or reply.type == "error" then failed(reply and reply.reason or tostring(rerr)) return end
      if self:_stopping_all(ch) then answered = true ch.restarting = nil cb(nil, ch.path .. ": stopped") return end
      answered = true
      ch.restarting, ch.state = nil, "inactive"
      self:_watch(name, handle)
      self:_restart_tail(name, was_running, cb)
    end)
  end)
end

-- A child started anew runs with its last init if it ran (or its run was asked for meanwhile) and the
-- expression still runs it.
function Sup:_run_again(name, was_running)
  local ch = self.children[name]
  local pending = ch.start_pending
  ch.start_pending, ch.policy_fault, ch.policy_restart = nil, nil, nil
  if (was_running or pending) and self.run and self.run:is_running(name) then self:_start_child(name, ch.init) end
end

function Sup:_restarted_line(ch)
  local pid = ch.handle and ch.handle.pid
  self:say("%s: restarted%s%s", ch.path, ch.restart_note or "", pid and sformat(" (pid %s)", tostring(pid)) or "")
end

--- Past the restart intensity: the running children stopped (LIFO), the group ended ABORTED with `reason`, its
--- outcome naming the first cause's path; the parent's policy (or algebra) takes it from there.
function Sup:_escalate(f, reason)
  local rec = self.recovering
  self.recovering, self.recovery_at = nil, f.at
  if rec then self:_unmark(rec) end
  -- the faults that waited for the restart are not restarted either: their children no longer wait for one
  self:_unfault(f)
  for _, q in ipairs(rec and rec.queue or {}) do self:_unfault(q) end
  if self.state ~= "running" then self.recovery_at = nil return end  -- aborted or stopped meanwhile: no outcome
  self.escalated = true
  self:say("%s: %s", self.path, reason)
  self.cause = { path = f.cause.path, reason = reason }
  if self.run and self.state == "running" then
    self.state = "aborting"
    self.run:abort()
  end
  self.state = "aborted"
  self.outcome = { status = "aborted", path = f.cause.path, reason = reason, escalated = true }
  self:say("%s: aborted (%s: %s)", self.path, f.cause.path, reason)
  self.recovery_at = nil
  self:_report({ type = "aborted", path = f.cause.path, reason = reason, escalated = true, now = now_ns(f.at) })
end

---------------------------------------------------------------------------------------------- stop

--- Aborts the expression, then stops every child process, most recently started first: a child group is
--- asked to shut down its own subtree (its answer comes when all of it is gone) before it is ended and the
--- next child is stopped; leaves are sent their stop signal in LIFO order. cb() once every child's exit was
--- seen (each wait is bounded: SIGKILL after a grace, then it is reported and given up).
function Sup:shutdown(cb)
  if self.state == "stopped" then if cb then cb() end return end
  if self.shutdown_waiters then
    -- a second shutdown (parent gone while its shutdown runs, Ctrl-C twice): answered with the first
    self.shutdown_waiters[#self.shutdown_waiters + 1] = cb
    return
  end
  self.shutdown_waiters = { cb }
  self:abort(function()
    self.state = "stopping"
    local names = {}
    for i = #self.order, 1, -1 do names[#names + 1] = self.order[i] end
    local waiting, i = 1, 0
    local function gone(ok, err)
      if not ok and err then self:say("%s: %s", self.path, tostring(err)) end
      waiting = waiting - 1
      if waiting > 0 then return end
      self.state = "stopped"
      self.order = {}
      local ws = self.shutdown_waiters
      self.shutdown_waiters = nil
      for _, w in ipairs(ws) do if w then w() end end
    end
    local function next_one()
      while true do
        i = i + 1
        local name = names[i]
        if not name then gone(true) return end
        local ch = self.children[name]
        local h = ch.handle
        ch.handle = nil
        ch.state = "gone"
        if h then
          waiting = waiting + 1
          if ch.kind == "group" then
            h.request({ type = "shutdown" }, self.timeouts.shutdown, function(_, err)
              if err then self:log("%s: shutdown of %s: %s", self.path, ch.path, tostring(err)) end
              h.kill("TERM", gone)
              next_one()
            end)
            return
          end
          h.kill("TERM", gone)
        end
      end
    end
    next_one()
  end)
end

---------------------------------------------------------------------------------------------- parent requests

--- A request from the parent (or the REPL/`dca run` on the root). reply(msg) answers it.
function Sup:handle(msg, reply)
  local t = msg.type
  if t == "configure" then
    -- the spec came with the DCAS's creation; a configure message may also carry it
    self:configure(function(ok, err)
      if ok then reply({ type = "ok" }) else
        self:shutdown(function() reply({ type = "error", reason = err }) end)
      end
    end)
  elseif t == "run" then
    -- answered once everything the start ran has answered its own run (a whole subtree is running)
    self.event_at = tonumber(msg.at)
    local answered = false
    local ok, err = self:run_expr(msg.init, function(started)
      if started and not answered then answered = true reply({ type = "ok" }) end
    end)
    self.event_at = nil
    if not ok and not answered then answered = true reply({ type = "error", reason = err }) end
  elseif t == "abort" then
    self:abort(function() reply({ type = "ok" }) end)
  elseif t == "shutdown" then
    self:shutdown(function() reply({ type = "ok" }) end)
  elseif t == "node" then
    self:to_leaf(msg.leaf, msg.msg, self.timeouts.request, function(r, err)
      reply(r or { type = "error", reason = err })
    end)
  elseif t == "tree" then
    self:tree(function(tr) reply({ type = "ok", tree = tr }) end)
  elseif t == "inject" or t == "restart" or t == "switch" then
    local function done(ok, err) reply(ok and { type = "ok" } or { type = "error", reason = err }) end
    if t == "inject" then self:inject(msg.path, msg.msg, done)
    elseif t == "restart" then self:restart(msg.path, done)
    else self:switch(msg.path, msg.label, msg.what, done) end
  elseif t == "ports" or t == "tap" then
    self:_tap(msg, reply)
  elseif t == "ping" then
    reply({ type = "ok", path = self.path, state = self.state })
  elseif t == "stats" then
    if msg.path and msg.path ~= self.path then
      self:_forward(msg.path, msg, function(r, err) reply(r or { type = "error", reason = err }) end)
    else
      reply({ type = "ok", stats = self.stats, path = self.path })
    end
  elseif t == "update" then
    self:update(msg.spec, function(lines) reply({ type = "ok", lines = lines }) end)
  elseif t == "repl" or t == "complete" then
    local repl = self.repl
    if not repl then
      if not self.console then reply({ type = "error", reason = self.path .. " has no console" }) return end
      repl = self.console(self)
      self.repl = repl
    end
    if t == "complete" then reply({ type = "ok", candidates = repl:complete(msg.prefix or "") })
    else repl:eval(msg.line or "", function(out, more) reply({ type = "ok", output = out, more = more }) end) end
  else
    reply({ type = "error", reason = "unknown request '" .. tostring(t) .. "'" })
  end
end

-- A console's taps (`dca monitor ADDR` plotting a port): `ports {}` --> {ports = taps.outputs of the tree, host,
-- sim (on simulated time: the samples' stamps mean something to a viewer)};
-- `tap {path = "a.b.P", to = NAME}` links that output to the tap input "tap:a.b.P" of the component NAME (a tap
-- point the console registered), through the tree as the root's own taps (so a restart makes it again).
function Sup:_tap(msg, reply)
  local types = self.rt.types and self.rt.types() or {}
  if msg.type == "ports" then reply({ type = "ok", ports = taps.outputs(self.spec, types), host = self.spec.host,
                                         sim = (self.rt.on_sim_time and self.rt.on_sim_time()) == true }) return end
  if type(msg.path) ~= "string" or type(msg.to) ~= "string" or msg.to == "" then
    reply({ type = "error", reason = "tap {path = 'a.b.PORT', to = 'NAME'}" }) return
  end
  local list, err = taps.select(self.spec, types, msg.path)
  if list and #list ~= 1 then list, err = nil, "tap one port at a time, not '" .. msg.path .. "'" end
  if not list then reply({ type = "error", reason = err }) return end
  taps.connect(self, list, msg.to, {}, function(ok, cerr)
    reply(ok and { type = "ok", port = list[1] } or { type = "error", reason = cerr })
  end)
end

-- The direct child of this group on the way to `path` (the child itself or the sub-group holding it).
function Sup:_via(path)
  for _, c in ipairs(self.spec.children) do
    local p = c.path .. "."
    if c.path == path or (c.kind == "group" and path:sub(1, #p) == p) then return self.children[c.name] end
  end
end

-- Forwards a request to the child DCAS on the way to `path`. cb(ok, err)
function Sup:_forward(path, msg, cb)
  local ch = self:_via(path)
  if not ch then cb(nil, sformat("no process '%s' under %s", path, self.path)) return end
  if ch.kind ~= "group" or not ch.handle then cb(nil, sformat("%s is not reachable (%s)", ch.path, ch.state)) return end
  ch.handle.request(msg, self.timeouts.request, function(r, err)
    if r and r.type ~= "error" then cb(r) else cb(nil, r and r.reason or tostring(err)) end
  end)
end

--- Injects an event (from the REPL or a scenario) as if the process at `path` had sent it to its owner.
function Sup:inject(path, msg, cb)
  local ch = self:_via(path)
  if ch and ch.path == path then
    -- the process is told to stop first (its run is over as far as the algebra is concerned), then the
    -- event is taken as if it had sent it
    if ch.kind == "leaf" and ch.handle and ch.state == "running" then
      ch.handle.request({ type = "stop" }, self.timeouts.stop, function() end)
    end
    self.rt.defer(function() self:child_message(ch.name, msg) end)
    cb(true)
  else
    self:_forward(path, { type = "inject", path = path, msg = msg }, cb)
  end
end

--- Restarts the process at `path`: a group's expression is aborted and started again (its latest event
--- actions take effect); a leaf is started anew from what is on disk now, while everything else runs
--- (Sup:restart_leaf, done by the leaf's own group). cb(true) | cb(nil, reason)
function Sup:restart(path, cb)
  if path == self.path then
    self:abort(function()
      local ok, err = self:run_expr(self.last_init)
      cb(ok, err)
    end)
    return
  end
  local ch = self:_via(path)
  -- (the breaks its leaves see while `path` is replaced are expected: Sup:_restarting_peer)
  self.restarting_below = self.restarting_below or {}
  self.restarting_below[path] = (self.restarting_below[path] or 0) + 1
  local function finish(ok, err)
    local n = self.restarting_below[path] - 1
    self.restarting_below[path] = n > 0 and n or nil
    cb(ok, err)
  end
  if ch and ch.kind == "leaf" then self:restart_leaf(ch.name, finish) return end
  self:_forward(path, { type = "restart", path = path }, function(ok, err)
    if not ok then finish(nil, err) return end
    -- a leaf below: this group's connections of it are made again before the answer (the `restarted` event
    -- does the same for the groups above one that restarts a leaf by itself; a connection made twice is one)
    self:_rewire(path, finish)
  end)
end

-- The path of the process being restarted through this group that the data peer `peer` ("PATH.port") is
-- part of, or nil.
function Sup:_restarting_peer(peer)
  if type(peer) ~= "string" then return nil end
  for path in pairs(self.restarting_below or {}) do
    if peer:sub(1, #path + 1) == path .. "." then return path end
  end
end

--- Activates/deactivates the connection set `label` of the process at `path` (in the group that owns it).
function Sup:switch(path, label, what, cb)
  local ch = self:_via(path)
  if ch and ch.path == path then
    local id = spec_mod.set_id(self.path, ch.name, label)
    if not (self.set_sources and self.set_sources[id]) then cb(nil, "no connection set " .. id) return end
    self:_set(ch.name, label, what)
    cb(true)
  else
    self:_forward(path, { type = "switch", path = path, label = label, what = what }, cb)
  end
end

local function same(a, b)
  if a == b then return true end
  if type(a) ~= "table" or type(b) ~= "table" then return false end
  for k, v in pairs(a) do if not same(v, b[k]) then return false end end
  for k in pairs(b) do if a[k] == nil then return false end end
  return true
end

--- Takes a new version of this group's spec (a reload): event actions changed take effect at the group's
--- next start; structural changes are reported (they need the system started again). cb(lines).
function Sup:update(new, cb)
  local lines = {}
  local old = self.spec
  local name = self.path .. " (" .. tostring(new.type) .. ")"
  local function shape(sp)
    local t = { children = {}, external_io = sp.external_io, sets = sp.sets, host = sp.host, type = sp.type,
                hosts = sp.hosts }
    for i, c in ipairs(sp.children) do t.children[i] = { c.name, c.kind, c.type, c.host, c.args, c.standby } end
    return t
  end
  if not same(shape(old), shape(new)) then
    lines[#lines + 1] = name .. ": processes or connections changed; takes effect when the system is started again"
  end
  if not same(old.supervision, new.supervision) then
    -- a policy is data: the new one applies from the next fault on (the restarts so far still count)
    self.spec.supervision = new.supervision
    lines[#lines + 1] = name .. ": supervision policy changed; in effect now"
  end
  if old.expr ~= new.expr then
    local algebra = require "dca.algebra"
    local e, err = algebra.parse(new.expr or "")
    if not e then
      lines[#lines + 1] = sformat("%s: new event actions rejected: %s", name, err)
    else
      self.spec.expr, self.spec.expr_line, self.spec.expr_col = new.expr, new.expr_line, new.expr_col
      if self.state == "running" then
        self.pending_expr = e
        lines[#lines + 1] = name .. ": event actions changed; takes effect at next start (or restart(\"" ..
          self.path .. "\") now)"
      else
        self.expr = e
        lines[#lines + 1] = name .. ": event actions changed; takes effect at next start"
      end
    end
  end
  local pending = 1
  local function fin()
    pending = pending - 1
    if pending == 0 then cb(lines) end
  end
  for _, c in ipairs(new.children) do
    local ch = self.children[c.name]
    if c.kind == "group" and ch and ch.kind == "group" and ch.handle then
      pending = pending + 1
      ch.handle.request({ type = "update", spec = c.spec }, self.timeouts.request, function(r, err)
        if r and r.lines then for _, l in ipairs(r.lines) do lines[#lines + 1] = l end
        else lines[#lines + 1] = sformat("%s: not updated: %s", c.path, r and r.reason or tostring(err)) end
        fin()
      end)
    end
  end
  fin()
end

--- The node of `path` in a tree (as Sup:tree gives it), or nil.
function M.find(node, path)
  if node.path == path then return node end
  for _, c in ipairs(node.children or {}) do
    local f = M.find(c, path)
    if f then return f end
  end
end

-- The time of the restart window: on simulated time (rt.on_sim_time()), the simulated time of the fault's event
-- (`at`; without one, the latest seen), else rt.now() (the memory runtime's simulated time, or the wall clock).
function Sup:_policy_now(at)
  if not (self.rt.on_sim_time and self.rt.on_sim_time()) then return self.rt.now() end
  self.sim_seen = math.max(self.sim_seen or 0, at or 0)
  return self.sim_seen
end

--- This group's policy and how much of its budget is used: { strategy, intensity, within, on = {...},
--- used = restarts in the window now, total = restarts so far, escalated = bool }, or nil without a policy.
function Sup:policy_status()
  local pol = self.spec.supervision
  if not pol then return nil end
  local used = policy.window(self.restart_times or {}, self:_policy_now(), pol.within)
  return { strategy = pol.strategy, intensity = pol.intensity, within = pol.within, on = pol.on, used = #used,
           total = self.restarts_total or 0, escalated = self.escalated or false }
end

--- The tree below this group: { path, kind, type, host, state, children = {...}, expr = rendered }. Async.
function Sup:tree(cb)
  local node = { path = self.path, kind = "group", type = self.spec.type, host = self.spec.host, state = self.state,
                 expr = self.run and self.run:render() or self.spec.expr, children = {}, policy = self:policy_status() }
  local pending = 1
  local function fin()
    pending = pending - 1
    if pending == 0 then cb(node) end
  end
  for i, c in ipairs(self.spec.children) do
    local ch = self.children[c.name]
    if c.kind == "leaf" then
      node.children[i] = { path = ch.path, kind = "leaf", type = c.type, host = ch.host, state = ch.state,
                           restarts = ch.restarts }
    else
      node.children[i] = { path = ch.path, kind = "group", type = c.type, host = ch.host, state = ch.state, children = {},
                           restarts = ch.restarts }
      if ch.handle then
        pending = pending + 1
        ch.handle.request({ type = "tree" }, self.timeouts.request, function(r)
          if r and r.tree then
            r.tree.state, r.tree.restarts = r.tree.state or ch.state, ch.restarts
            node.children[i] = r.tree
          end
          fin()
        end)
      end
    end
  end
  fin()
end

return M
