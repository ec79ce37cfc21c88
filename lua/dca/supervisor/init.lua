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
--   sup:restart(path, cb, opts) -- a group below: its expression again; a leaf below: a fresh process of it, wired
--                             --   and running as before while the rest runs (sup:restart_leaf(name, cb) in the
--                             --   leaf's own group). cb(true) | cb(nil, reason). opts.own_process: a leaf in a
--                             --   shared node moves to a process of its own (an upgrade: restart.code_check)
--   sup:restart_host(ch, fault)  -- hook (failover): the host a child restarts on after `fault` (nil: its own)
--   sup:policy_status()       -- the group's supervision policy and its budget used (nil without a policy)
-- With spec.supervision, faults of its children are restarted by the policy (section "supervision policy").
--   sup:handle(msg, reply)    -- a request from the parent (configure/run/abort/shutdown/node/tree/...)
--   sup:child_message(name, msg)  -- an event from a child (leaf node: done/aborted; child DCAS: done/aborted/log/
--                                 --   restarted {path}: a leaf below was restarted, its connections made again;
--                                 --   the world's second_writer {input, writer, holder}: a leaf's samples refused)
--   sup:output(path, line)    -- a line a child process wrote to its stderr, said as `path: line`
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
--   rt.fenced(host, cb)       -- optional: cb(waited_s | nil) once the leases this group held at `host` lapsed
--                             --   (fencing: a child moved off a lost host starts after it)
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
-- updates in place, so running supervisors pick up new code and keep their state. The modules beside this one
-- hold the rest of the engine as functions over the supervisor (dca.reload updates each in place):
--   dca.supervisor.child     a child's record, its states and their transitions (child.set)
--   dca.supervisor.wiring    connections and device ports (start, restart), commands to leaves (to_leaf)
--   dca.supervisor.restart   manual restarts and the supervision policy's (take-down, bring-up, escalation)
--   dca.supervisor.requests  the requests a supervisor answers, one handler per type
--   dca.supervisor.taps      taps on output ports, and the taps a restart makes again
--   dca.supervisor.live      live parameters: a change of a leaf's config("key") told to the leaf while it runs
-- This file is the start protocol (new, configure), the expression (run), the children's events, shutdown and
-- tree.
local previous = package.loaded["dca.supervisor"]
local M = type(previous) == "table" and previous or {}

local algebra = require "dca.algebra"
local async = require "dca.async"
local child = require "dca.supervisor.child"
local fleet = require "dca.supervisor.fleet"
local live = require "dca.supervisor.live"
local policy = require "dca.supervisor.policy"
local requests = require "dca.supervisor.requests"
local restart = require "dca.supervisor.restart"
local spec_mod = require "dca.supervisor.spec"
local wiring = require "dca.supervisor.wiring"

local ipairs, pairs, type, tostring, sformat, select, tonumber = ipairs, pairs, type, tostring, string.format, select, tonumber
local concat = table.concat

--- Timeouts (seconds) of each wait of the start protocol; any of them may be overridden per supervisor.
M.timeouts = M.timeouts or { spawn = 10, configure = 30, connect = 5, stop = 5, request = 5 }
M.timeouts.shutdown = M.timeouts.shutdown or 30   -- a child group's whole subtree gone (each exit bounded)

M.Sup = M.Sup or {}
local Sup = M.Sup
Sup.__index = Sup

local LOG_KEEP = 500

-- A value as the run's lines and trace show it, the same in every run: a `,` list ({ n = k, ... } in text order)
-- item by item with its holes as nil, any other table by its keys in order (pairs' order is not the same from run
-- to run: integer keys set in completion order, and string keys hashed with a per-process seed).
local SHOW_MAX = 8
local function key_order(a, b)
  local ta, tb = type(a), type(b)
  if ta ~= tb then return ta < tb end
  if ta == "number" or ta == "string" then return a < b end
  return tostring(a) < tostring(b)
end
local function show(v)
  if v == nil then return "nil" end
  if type(v) == "string" then return sformat("%q", v) end
  if type(v) ~= "table" then return tostring(v) end
  local parts = {}
  if math.type(v.n) == "integer" then
    for i = 1, math.min(v.n, SHOW_MAX) do parts[i] = show(v[i]) end
    if v.n > SHOW_MAX then parts[#parts + 1] = "..." end
    return "{" .. concat(parts, ", ") .. "}"
  end
  local keys = {}
  for k in pairs(v) do keys[#keys + 1] = k end
  table.sort(keys, key_order)
  for i, k in ipairs(keys) do
    if i > SHOW_MAX then parts[#parts + 1] = "..." break end
    parts[i] = (math.type(k) == "integer" and "" or tostring(k) .. "=") .. show(v[k])
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
    self.children[c.name] = child.new(c)
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
  if self.upgrade_tap then self.upgrade_tap(line) end  -- a rolling upgrade watches its hosts (dca.supervisor.upgrade)
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

--- A line the process of `path` (a leaf, a child supervisor, a shared node) wrote to its stderr, for the person
--- watching as `path: line`, as a transition line goes (docs/processes.md, "Output"); `output` marks it so (a
--- recording keeps it on /dca/log). It is not kept in this supervisor's log: that is for its transitions.
function Sup:output(path, line)
  local text = sformat("%s: %s", path, line)
  if self.progress then self.rt.report({ type = "log", line = text, output = path, at = self.event_at })
  elseif self.rt.log then self.rt.log(text) end
end

local function now_ns(at) return at and math.floor(at * 1e9 + 0.5) or nil end

---------------------------------------------------------------------------------------------- start

-- Phase 1: every child process started (inactive); groups configured (their subtree up and wired).
-- A failure is reported (cb(nil, reason), the first one) only once every spawn in flight has answered or
-- timed out, so that the shutdown which follows finds every process that was started; a handle that still
-- arrives after that (a spawn answered after its timeout) is killed on arrival.
function Sup:_start_children(cb)
  local j, failed = async.join(cb), false
  for _, c in ipairs(self.spec.children) do
    local k = j.add()
    self:_start_one(self.children[c.name], function(ok, why)
      if not ok then failed = true end
      k(ok, why)
    end, function() return failed end)
  end
  j.close()
end

-- The process of child `ch` started (a group's also configured): k(true) | k(nil, reason), once. failed() says
-- whether the start of another child failed meanwhile: a group is then not configured (the shutdown that
-- follows stops its supervisor).
function Sup:_start_one(ch, k, failed)
  local answered = false
  child.set(ch, "starting")
  local timer = self.rt.after(self.timeouts.spawn, function()
    if ch.state == "starting" and not answered then
      answered = true
      k(nil, sformat("%s (%s on host %s) did not start within %gs", ch.path, ch.kind == "group" and "supervisor"
        or "node", tostring(ch.host), self.timeouts.spawn))
    end
  end)
  self.rt.spawn(ch.spec, function(handle, err, how)
    if timer then timer:cancel() end
    if answered then
      -- too late: the start already failed; whatever started is stopped at once
      if handle then handle.kill("KILL") end
      return
    end
    answered = handle == nil or ch.kind == "leaf" or failed()
    if not handle then
      child.set(ch, "failed")
      -- said at the leaf at once: the start's error waits for the other spawns in flight
      local why = child.start_error(ch, err, how)
      self:say("%s", why)
      k(nil, why)
      return
    end
    ch.handle = handle
    self.order[#self.order + 1] = ch.name
    if answered then child.set(ch, "inactive") k(true) return end
    child.set(ch, "configuring")
    handle.request(self:_configure_msg(ch), self.timeouts.configure, function(reply, rerr, error_reply)
      if answered then return end
      answered = true
      if async.outcome(reply, rerr) then
        child.set(ch, "inactive")
        self:_watch(ch.name, handle)
        k(true)
        return
      end
      child.set(ch, "failed")
      -- an error reply carries the child's own reason (naming what failed below it); else no answer
      k(nil, reply and reply.reason or (error_reply and rerr) or
        sformat("%s (supervisor on host %s) did not answer: %s", ch.path, tostring(ch.host), tostring(rerr)))
    end)
  end)
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
      -- its channel closed: not silence. Its exit, or its host's loss, follows and names the real reason (the
      -- process's channel_closed waits at most exit_grace for it: dca.supervisor.net)
      if tostring(err):find("closed") then return end
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

-- The start protocol below this group, its steps in order; each step(sup, k) calls k(true) | k(nil, reason).
local START = {
  -- phase 1: every child process started, inactive; child groups configured (their subtree up and wired)
  function(self, k)
    self:say("%s: starting %d processes", self.path, #self.spec.children)
    self:_start_children(function(ok, err)
      if ok then self:say("%s: started", self.path) end
      k(ok, err)
    end)
  end,
  -- phase 2: this group's own connections, resolved to leaf ports, created inactive at each source node
  function(self, k)
    wiring.connect(self, function(ok, err)
      if ok then self:say("%s: connected (%d connections)", self.path, #self.wires) end
      k(ok, err)
    end)
  end,
  -- phase 2b: the device ports of this group's leaves wired to the robot process `world`, active for good
  function(self, k)
    wiring.devices(self, function(ok, err)
      if ok and #self.device_ports > 0 then
        self:say("%s: %d device ports wired to the world", self.path, #self.device_ports)
      end
      k(ok, err)
    end)
  end,
  -- on simulated time, this supervisor takes part in the clock's barrier (dca.supervisor.lockstep)
  function(self, k)
    if not self.rt.join_clock then k(true) return end
    self.rt.join_clock(self.path, k)
  end,
  -- the configuration keys its leaves read, watched: a change reaches their live parameters (dca.supervisor.live)
  function(self, k) live.watch(self, k) end,
  -- a fresh supervisor of a group that had instances added (a restart of it): they come up again
  function(self, k) fleet.restore(self, k) end,
}

--- Start protocol below this group: children started inactive, then connected. cb(true) | cb(nil, reason).
function Sup:configure(cb)
  if self.expr_error then self.state = "failed" cb(nil, self.expr_error) return end
  self.state = "starting"
  async.each_in_order(START, function(step, _, next)
    step(self, function(ok, err)
      if not ok then self.state = "failed" cb(nil, err) return end
      next()
    end)
  end, function()
    self.state = "configured"
    self:say("%s: configured", self.path)
    cb(true)
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
  -- kept so that a restarted source's sets are activated again (wiring.rewire)
  self.active_sets = self.active_sets or {}
  self.active_sets[id] = what == "activate" or nil
  for _, src in ipairs(srcs) do wiring.at_source(self, src, { type = what, set = id }) end
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
  if child.restart(ch, "fault") or child.restart(ch, "policy") then
    -- being restarted by the group's policy: it runs once its new process is up (restart.run_again)
    ch.init = init
    child.mark(ch, { pending = true })
    self:say("%s: running once restarted", ch.path)
    return
  end
  if not ch.handle or ch.state == "exited" or ch.state == "lost" then
    self:_fail_later(name, sformat("%s is not running (%s)", ch.path, ch.exit_reason or ch.state))
    return
  end
  child.set(ch, "running")
  ch.init = init                 -- a restarted leaf runs again with it (Sup:restart_leaf)
  ch.run_no = (ch.run_no or 0) + 1
  local run_no = ch.run_no
  self:say("%s: running", ch.path)
  local function check(reply, err)
    local ok, why = async.outcome(reply, err)
    if not ok and ch.state == "running" and ch.run_no == run_no then
      -- a channel closed: the process's exit (or its loss, at most exit_grace later: dca.supervisor.net) follows
      -- with the real reason (its signal, its code), and the algebra or the policy takes that
      if not reply and tostring(err):find("closed") then return end
      -- the reason goes with the leaf's path wherever it is said: a controller's own "<Type> <path>: ..." keeps
      -- its type only (the path once, not three times)
      local plain = ch.path:gsub("%p", "%%%0")
      self:_fail_later(name, (tostring(why):gsub("^(%w[%w.]*) " .. plain .. "([: ])", "%1%2", 1)))
    end
  end
  -- while run_expr starts the expression, the answers to these runs are joined (run_expr's cb)
  local acked = self.run_acks and self.run_acks.add()
  local function ran(reply, err)
    check(reply, err)
    if acked then acked(true) end
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
  child.unmark(ch, "pending")
  -- a leaf whose process already ended (with others of its shared node: children_exit) has nothing to stop
  local dead = ch.state == "exited"
  if not dead then
    child.set(ch, "stopping")
    self:say("%s: aborting", ch.path)
  end
  local acked = self.abort_ack and self.abort_ack.add()
  self.stops_pending = (self.stops_pending or 0) + 1
  local function done(reply, err)
    if ch.state == "stopping" then child.set(ch, "inactive") end
    local ok, why = async.outcome(reply, err)
    if not ok then self:log("%s: stop of %s: %s", self.path, ch.path, why) end
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
    if acked then acked(true) end
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
  if st == "done" or st == "aborted" then fleet.stop_all(self) end
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
  for _, ch in pairs(self.children) do child.unmark(ch, "fault", "pending") end
  self.state = "running"
  self.last_init = init
  self.run = algebra.new(self.expr, self:_commands())
  local acks = async.join(function() if started then started(true) end end)
  self.run_acks = acks
  self.run:start(init)
  fleet.run_all(self)   -- (the instances of its templates run beside the expression)
  self.run_acks = nil
  acks.close()
  self:_check_outcome()
  return true
end

--- Aborts the running expression (one LIFO abort); cb() once every abort is acknowledged. With `reason`
--- (the group aborted by a person: the REPL's abort(), the monitor), the group's ABORTED outcome goes up as
--- any outcome, so the parent's algebra (or, at the root, `dca run`) sees the group end; without it (the
--- parent's own abort, a restart, a shutdown) nothing is reported.
function Sup:abort(cb, reason)
  if not self.run or self.state ~= "running" then if cb then cb() end return end
  local ack = async.join(function() if cb then cb() end end)
  self.abort_ack = ack
  self.state = "aborting"
  self.run:abort()
  fleet.stop_all(self)
  self.abort_ack = nil
  self.state = "aborted"
  self.outcome = { status = "aborted", path = self.path, reason = reason or "aborted by its parent" }
  -- aborted by a person: "aborted"; stopped by its parent (disabled by `#`, a restart, the shutdown): "stopped",
  -- as the parent says of a leaf it stops (the run's summary takes the first end word as the step's)
  self:say(reason and "%s: aborted" or "%s: stopped", self.path)
  if reason then self:_report({ type = "aborted", path = self.path, reason = reason, now = now_ns(self.event_at) }) end
  ack.close()
end

---------------------------------------------------------------------------------------------- events

--- A message from child `name`: a leaf node's done/aborted event, or a child DCAS's done/aborted/log.
function Sup:child_message(name, msg)
  local ch = self.children[name]
  if not ch then return end
  local t = msg.type
  if t == "log" then
    if self.progress then self.rt.report(msg) end
    if not msg.output then self:log("%s", msg.line) end
    return
  end
  if t == "restarted" then restart.leaf_restarted(self, msg.path) return end
  if t == "fleet" then fleet.child_changed(self, ch, msg) return end
  if child.restart(ch, "replacing") and (t == "done" or t == "aborted") then
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
  if t == "done" then self:_child_done(name, ch, msg)
  elseif t == "aborted" then self:_child_aborted(name, ch, msg)
  elseif t == "broken" or t == "overflow" then self:_data_event(ch, msg)
  elseif t == "second_writer" then self:_second_writer(ch, msg) end
  if pending0 == 0 and (self.stops_pending or 0) > 0 then self.event_t0 = t0 end
  self.event_at = saved_at
end

-- A child's DONE: an event of the algebra when it runs the child.
function Sup:_child_done(name, ch, msg)
  if fleet.owns(self, name) then
    if not fleet.runs(self, name) then self:log("%s: stale done from %s ignored", self.path, ch.path) return end
    child.set(ch, "done")
    fleet.ended(self, name, "done", show(msg.value))
    return
  end
  local taken = self.run and self.run:is_running(name)
  if taken then
    child.set(ch, "done")
    if ch.kind == "leaf" then self:say("%s: done %s", ch.path, show(msg.value)) end
  end
  if not self:_feed(name, "done", msg.value) and not taken then
    self:log("%s: stale done from %s ignored", self.path, ch.path)
  end
end

-- A data connection of leaf `ch` broke or overflowed: worth a line, not an event of the algebra (the process at
-- the other end, if it died, is reported by its own owner).
function Sup:_data_event(ch, msg)
  local t = msg.type
  -- a device input holds the robot's latest sample (a queue of one): the older one dropped is expected
  if t == "overflow" and wiring.is_device_input(self, ch.path, msg.port) then return end
  local peer = msg.peer and (" <-> " .. tostring(msg.peer)) or ""
  local restarting = t == "broken" and restart.restarting_peer(self, msg.peer)
  if t == "broken" and (self.shutdown_waiters or self.state == "stopping" or self.state == "stopped"
                        or ch.state ~= "running" or restarting) then
    -- the tree is being stopped (the process at the other end was stopped first, LIFO), this leaf does not
    -- run, or the other end is being restarted (its connections are made again): kept in the log only
    self:log("%s: broken %s%s: %s (%s)", ch.path, tostring(msg.port), peer, tostring(msg.reason),
      self.shutdown_waiters and "while stopping" or restarting and ("while " .. restarting .. " restarts")
      or ("while " .. tostring(ch.state)))
    return
  end
  self:say("%s: %s %s%s: %s", ch.path, t, tostring(msg.port), peer, tostring(msg.reason))
end

-- The world refused samples of leaf `ch` on a device input another writer holds (docs/safety.md): a line with
-- both paths, and the event in the log. Not an event of the algebra: the leaf runs on, its samples refused.
function Sup:_second_writer(ch, msg)
  self:say("%s: second writer refused on %s: %s, held by %s", ch.path, tostring(msg.input), tostring(msg.writer),
    tostring(msg.holder))
end

-- A child's ABORTED (a leaf's Abort, a sub-group's outcome): restarted by the group's policy when it covers the
-- fault (the algebra sees nothing), else an event of the algebra.
function Sup:_child_aborted(name, ch, msg)
  local path, reason = msg.path or ch.path, msg.reason or "aborted"
  local taken = self:_runs(name)
  local how = ch.kind == "group" and msg.escalated and "escalated" or "aborted"
  local kind = policy.kind(how)
  if taken and restart.policy_takes(self, kind) then
    child.set(ch, "aborted")
    self:say("%s: %s: %s", ch.path, how, reason)
    restart.fault(self, { name }, how, kind, reason, { path = path, reason = reason })
    return
  end
  if fleet.owns(self, name) then
    if taken then child.set(ch, "aborted") fleet.ended(self, name, how, reason) end
    return
  end
  if taken then
    child.set(ch, "aborted")
    self:say("%s: aborted: %s", ch.path, reason)
    self.cause = self.cause or { path = path, reason = reason }
  end
  if not self:_feed(name, "aborted", reason) and not taken then
    self:log("%s: stale aborted from %s ignored", self.path, ch.path)
  end
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
    if child.restart(ch, "replacing") then
      -- the old process of a leaf being restarted: its exit was asked for, not a crash
      self:log("%s: old process exited (%s)", ch.path, tostring(reason))
      goto next
    end
    if restart.policy_takes(self, kind) then faulted[#faulted + 1] = name
    elseif self:_runs(name) then ran[#ran + 1] = name end
    child.set(ch, ch.kind == "leaf" and "exited" or "lost")
    ch.exit_reason = reason
    ch.handle = nil
    self:say("%s: %s: %s", ch.path, ch.kind == "leaf" and "exited" or "lost", reason)
    ::next::
  end
  -- the group's supervision policy restarts these (one fault, whichever number of leaves it ended)
  if #faulted > 0 then restart.fault(self, faulted, "exit", kind, reason) end
  for _, name in ipairs(ran) do
    if fleet.owns(self, name) then fleet.ended(self, name, lost and "lost" or "exited", reason) goto fed end
    self.cause = self.cause or { path = self.children[name].path, reason = reason }
    self:_feed(name, "error", reason)
    ::fed::
  end
  local first = self.children[names[1]]
  if self.starting_cb and first then
    local f = self.starting_cb
    self.starting_cb = nil
    f(nil, sformat("%s: %s", first.path, reason))
  end
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
  live.unwatch(self)
  self:abort(function()
    self.state = "stopping"
    local names = {}
    for i = #self.order, 1, -1 do names[#names + 1] = self.order[i] end
    -- each exit seen: stopped
    local exits = async.join(function()
      self.state = "stopped"
      self.order = {}
      local ws = self.shutdown_waiters
      self.shutdown_waiters = nil
      for _, w in ipairs(ws) do if w then w() end end
    end)
    async.each_in_order(names, function(name, _, next)
      local ch = self.children[name]
      local h = ch.handle
      ch.handle = nil
      child.set(ch, "gone")
      if not h then next() return end
      local exited = exits.add()
      local function gone(ok, err)
        if not ok and err then self:say("%s: %s", self.path, tostring(err)) end
        exited(true)
      end
      if ch.kind ~= "group" then h.kill("TERM", gone) next() return end
      h.request({ type = "shutdown" }, self.timeouts.shutdown, function(_, err)
        if err then self:log("%s: shutdown of %s: %s", self.path, ch.path, tostring(err)) end
        h.kill("TERM", gone)
        next()
      end)
    end, exits.close)
  end)
end

---------------------------------------------------------------------------------------------- routing

--- Whether child `name` runs now: the expression runs it, or it is an instance of a template the group runs
--- (dca.supervisor.fleet).
function Sup:_runs(name)
  return (self.run ~= nil and self.run:is_running(name)) or fleet.runs(self, name)
end

-- The direct child of this group on the way to `path` (the child itself or the sub-group holding it).
function Sup:_via(path)
  for _, c in ipairs(self.spec.children) do
    local p = c.path .. "."
    if c.path == path or (c.kind == "group" and path:sub(1, #p) == p) then return self.children[c.name] end
  end
end

-- Forwards a request to the child DCAS on the way to `path` (within `timeout` s, default the request's). cb(ok, err)
function Sup:_forward(path, msg, cb, timeout)
  local ch = self:_via(path)
  if not ch then cb(nil, sformat("no process '%s' under %s", path, self.path)) return end
  if ch.kind ~= "group" or not ch.handle then cb(nil, sformat("%s is not reachable (%s)", ch.path, ch.state)) return end
  ch.handle.request(msg, timeout or self.timeouts.request, function(r, err) cb(async.outcome(r, err)) end)
end

---------------------------------------------------------------------------------------------- tree

--- The node of `path` in a tree (as Sup:tree gives it), or nil.
function M.find(node, path)
  if node.path == path then return node end
  for _, c in ipairs(node.children or {}) do
    local f = M.find(c, path)
    if f then return f end
  end
end

--- This group's policy and how much of its budget is used: { strategy, intensity, within, on = {...},
--- used = restarts in the window now, total = restarts so far, escalated = bool }, or nil without a policy.
function Sup:policy_status()
  local pol = self.spec.supervision
  if not pol then return nil end
  local used = policy.window(self.restart_times or {}, restart.policy_now(self), pol.within)
  return { strategy = pol.strategy, intensity = pol.intensity, within = pol.within, on = pol.on, used = #used,
           total = self.restarts_total or 0, escalated = self.escalated or false }
end

--- The tree below this group: { path, kind, type, host, state, children = {...}, expr = rendered, estop =
--- {latched, t, source} (the emergency stop as this group last heard of it: dca.supervisor.requests) }. Async.
function Sup:tree(cb)
  local node = { path = self.path, kind = "group", type = self.spec.type, host = self.spec.host, state = self.state,
                 expr = self.run and self.run:render() or self.spec.expr, children = {}, policy = self:policy_status(),
                 estop = self.estop, fleet = self.spec.templates and fleet.list(self) or nil }
  local j = async.join(function() cb(node) end)
  for i, c in ipairs(self.spec.children) do
    local ch = self.children[c.name]
    if c.kind == "leaf" then
      node.children[i] = { path = ch.path, kind = "leaf", type = c.type, host = ch.host, state = ch.state,
                           restarts = ch.restarts, rt = c.rt and true or nil }
    else
      node.children[i] = { path = ch.path, kind = "group", type = c.type, host = ch.host, state = ch.state, children = {},
                           restarts = ch.restarts }
      if ch.handle then
        local k = j.add()
        ch.handle.request({ type = "tree" }, self.timeouts.request, function(r)
          if r and r.tree then
            r.tree.state, r.tree.restarts = r.tree.state or ch.state, ch.restarts
            node.children[i] = r.tree
          end
          k(true)
        end)
      end
    end
  end
  j.close()
end

---------------------------------------------------------------------------------------------- operations
-- The public operations whose work lives beside this file (see each module's header).
function Sup:to_leaf(leaf_path, msg, timeout, cb) return wiring.to_leaf(self, leaf_path, msg, timeout, cb) end
function Sup:handle(msg, reply) return requests.handle(self, msg, reply) end
function Sup:inject(path, msg, cb) return requests.inject(self, path, msg, cb) end
function Sup:switch(path, label, what, cb) return requests.switch(self, path, label, what, cb) end
function Sup:update(new, cb) return requests.update(self, new, cb) end
function Sup:restart(path, cb, opts) return restart.manual(self, path, cb, opts) end
function Sup:restart_leaf(name, cb) return restart.leaf(self, name, cb) end
function Sup:restart_host(ch, f) return restart.host(self, ch, f) end

--- An instance of the template at `path` (in this group or below) on `host`, started and (the group running)
--- run; remove_child(path[, host]): the instance at `path` (or the template's on `host`) stopped and ended.
--- cb(true, instance path) | cb(nil, reason). (dca.supervisor.fleet; docs/supervision.md, "A fleet")
function Sup:add_child(path, host, cb)
  if fleet.here(self, path) then return fleet.add(self, path, host, cb) end
  local ch = self:_via(path)
  if ch and ch.path == path then cb(nil, sformat("%s is a %s, not a template", path, ch.kind)) return end
  self:_forward(path, { type = "add_child", path = path, host = host }, function(r, err)
    if not r then cb(nil, err) return end
    cb(true, r.path)
  end, self.timeouts.spawn + self.timeouts.configure + self.timeouts.request)
end
function Sup:remove_child(path, host, cb)
  if fleet.here(self, path) then return fleet.remove(self, path, host, cb) end
  self:_forward(path, { type = "remove_child", path = path, host = host }, function(r, err)
    if not r then cb(nil, err) return end
    cb(true, r.path)
  end, self.timeouts.shutdown + self.timeouts.request)
end

return M
