-- dca.supervisor.restart: a child of a group started anew, by hand or by the group's supervision policy, as
-- functions over (sup, child name). The supervisor (dca.supervisor) keeps the state; this module only acts on it.
--
--   restart.manual(sup, path, cb, opts) -- the process at `path`: this group (its expression again), a leaf of
--                                   --   it (restart.leaf), or a process below (through the child supervisor)
--   restart.leaf(sup, name, cb, opts) -- the leaf `name` of this group anew, wired and running as before
--   restart.code_check(sup, ch, cb, opts) -- whether leaf `ch` may start anew with the code on disk now (shared
--                                   --   nodes); opts.own_process: it moves to a process of its own in any case
--   restart.policy_takes(sup, kind) --> whether the group's policy restarts a fault of `kind` now
--   restart.fault(sup, names, how, kind, reason, cause)  -- a fault for the policy (handled from the loop)
--   restart.host(sup, ch, f)        --> the host child `ch` restarts on after fault `f` (failover), or nil
--   restart.leaf_restarted(sup, path)  -- a leaf below was restarted: this group's connections of it again
--   restart.restarting_peer(sup, peer) --> the path being restarted that the data peer "PATH.port" is part of
--   restart.policy_now(sup, at)     --> the time of the restart window
-- The rest are its steps: take-down, bring-up (respawn, adopt, restore, tail), failure, escalation.
--
-- Restart of a leaf, by hand: the old process is stopped (Stop(): actuators at zero) and ended, a fresh one of the
-- same instance (type, arguments, host; its `config("key")` arguments read again) is started, its ports are
-- checked against the system's connections of them (a rebuild may have changed them: a misfit fails the restart,
-- never half-wired), the connections of the leaf are made again in both directions by every group that owns one (this one, then each ancestor as the
-- `restarted {path}` event goes up), its active sets are activated again, and it is run again with its `init` if
-- it was running. The algebra sees nothing: no event of the old process counts, and its exit is not a crash.
-- Other processes never stop.
local M = {}

local async = require "dca.async"
local child = require "dca.supervisor.child"
local failover = require "dca.supervisor.failover"
local policy = require "dca.supervisor.policy"
local taps = require "dca.supervisor.taps"
local wiring = require "dca.supervisor.wiring"

local ipairs, pairs, type, tostring, setmetatable = ipairs, pairs, type, tostring, setmetatable
local sformat, concat = string.format, table.concat

local function now_ns(at) return at and math.floor(at * 1e9 + 0.5) or nil end

---------------------------------------------------------------------------------------------- restart of a leaf

local RESTARTABLE = { inactive = true, running = true, done = true, aborted = true }

-- Why leaf `name` cannot be restarted now (nil: it can).
local function not_restartable(sup, name)
  local ch = sup.children[name]
  if not ch or ch.kind ~= "leaf" then return sformat("%s has no leaf '%s'", sup.path, tostring(name)) end
  if child.restart(ch, "replacing") then return ch.path .. " is already being restarted" end
  if not ch.handle or not RESTARTABLE[ch.state] then
    return sformat("%s is not running (%s)", ch.path, ch.exit_reason or ch.state)
  end
end

--- Starts the leaf `name` of this group anew (see above). cb(true[, note]) once it is started, wired and (if it
--- was running) running again (note: how, for a leaf in a shared node: M.code_check); cb(nil, reason) if it
--- cannot be restarted (the leaf untouched, running on) or if the restart failed (the leaf then ended ABORTED
--- with the reason, as for any abort).
function M.leaf(sup, name, cb, opts)
  local why = not_restartable(sup, name)
  if why then cb(nil, why) return end
  local ch, old = sup.children[name], sup.children[name].handle
  M.code_check(sup, ch, function(ok, how)
    if not ok then sup:say("%s", how) cb(nil, how) return end
    why = not_restartable(sup, name) or (ch.handle ~= old and ch.path .. " was restarted meanwhile") or nil
    if why then cb(nil, why) return end
    M.replace(sup, name, how, cb)
  end, opts)
end

--- How leaf `ch` starts anew, asked before anything of it stops. A leaf in a shared node (`--placement
--- group|host`) with other leaves starts anew in that same process, which cannot replace a package it loaded:
--- when the node says the leaf's package file changed since it loaded it, the leaf moves to a process of its
--- own (`own_process`: net.lua), which loads the file as it is now; else it stays, with a note that it reuses
--- the process's code. `opts.own_process` (a package upgrade: its daemon installed a new version, which a
--- process it starts now loads, while the node's own search path may not show it) moves it out in any case. A
--- leaf alone in its node gets a fresh node (its supervisor lets go of the old one), so it goes on, said too.
--- cb(true[, note]) | cb(nil, reason)
function M.code_check(sup, ch, cb, opts)
  if (sup.placement or "process") == "process" then cb(true) return end
  ch.handle.request({ type = "code" }, sup.timeouts.request, function(r, err)
    local info, why = async.outcome(r, err)
    if not info then
      cb(nil, sformat("restart of %s refused: its node did not say which code it runs: %s", ch.path, why))
      return
    end
    if not info.shared then cb(true) return end
    local others = (tonumber(info.leaves) or 1) - 1
    local where = sformat("shared node %s (--placement %s)", tostring(info.shared), sup.placement)
    if others == 0 then
      -- its supervisor lets go of the node with its last leaf: it starts in a fresh one (docs/placement.md)
      cb(true, sformat("alone in %s: a fresh process, with the code as it is on disk now", where))
      return
    end
    local upgrade = opts and opts.own_process
    if upgrade or info.changed then
      -- a package loaded in a process cannot be replaced there: the leaf leaves the shared node for a process
      -- of its own, which loads the file as it is on disk now (and stays its own at later restarts)
      ch.spec.own_process = true
      local why = upgrade and sformat("it loads package '%s' as its host has it now", tostring(info.package))
        or sformat("package '%s' is not what that process loaded (%s) and cannot be replaced there; it runs the "
          .. "code as it is on disk now", tostring(info.package), tostring(info.changed))
      cb(true, sformat("moved out of %s (%d other lea%s) to a process of its own: %s", where, others,
        others == 1 and "f" or "ves", why))
      return
    end
    cb(true, sformat("a fresh instance in %s, with the code that process loaded%s", where,
      info.package and sformat(": package '%s' is unchanged on disk", tostring(info.package)) or ""))
  end)
end

-- The restart of leaf `name` once it may (M.leaf): its old process stopped and ended, then M.respawn. `note`
-- (M.code_check's) goes with the transition line and the answer.
function M.replace(sup, name, note, cb)
  local ch = sup.children[name]
  local was_running = ch.state == "running" and sup:_runs(name)
  local old = ch.handle
  child.mark(ch, { replacing = true, code = note })
  child.set(ch, "restarting")
  ch.restarts = (ch.restarts or 0) + 1   -- (counted as a policy's are: the tree and the page's count agree)
  sup:say("%s: restarting", ch.path)
  local function ended(ok, err)
    if not ok then M.failed(sup, name, was_running, err, cb) return end
    ch.handle = nil
    if M.stopping_all(sup, ch) then child.unmark(ch, "replacing") cb(nil, ch.path .. ": stopped while restarting") return end
    M.respawn(sup, name, was_running, cb)
  end
  if was_running then
    old.request({ type = "stop" }, sup.timeouts.stop, function(r, err)
      local ok, why = async.outcome(r, err)
      if not ok then sup:log("%s: stop of %s: %s", sup.path, ch.path, why) end
      old.kill("TERM", ended)
    end)
  else
    old.kill("TERM", ended)
  end
end

-- The fresh process of leaf `name` (its old one ended), then M.adopt. A spawn failure fails the restart.
function M.respawn(sup, name, was_running, cb)
  local ch = sup.children[name]
  local answered = false
  local timer = sup.rt.after(sup.timeouts.spawn, function()
    if answered then return end
    answered = true
    M.failed(sup, name, was_running, sformat("%s (node on host %s) did not start within %gs", ch.path,
      tostring(ch.host), sup.timeouts.spawn), cb)
  end)
  sup.rt.spawn(ch.spec, function(handle, err, how)
    if timer then timer:cancel() end
    if answered then if handle then handle.kill("KILL") end return end
    answered = true
    if not handle then M.failed(sup, name, was_running, child.start_error(ch, err, how), cb) return end
    M.adopt(sup, name, was_running, handle, cb)
  end)
end

-- The fresh process `handle` of leaf `name` becomes the leaf's once its ports fit the system's uses of them
-- (wiring.check_ports: a rebuild may have renamed or retyped one), then M.restore. A misfit is never wired: the
-- process is ended and the restart fails with the reason (the leaf ends ABORTED, as after a failed start).
function M.adopt(sup, name, was_running, handle, cb)
  local ch = sup.children[name]
  local function stopped()
    if not M.stopping_all(sup, ch) then return false end
    child.unmark(ch, "replacing")
    handle.kill("TERM")
    cb(nil, ch.path .. ": stopped while restarting")
    return true
  end
  if stopped() then return end
  wiring.check_ports(sup, ch.path, handle, function(ok, why)
    if not ok then handle.kill("KILL") M.failed(sup, name, was_running, why, cb) return end
    if stopped() then return end
    ch.handle = handle   -- from here on its exit is a crash like any other
    child.unmark(ch, "replacing")
    child.set(ch, "inactive")
    M.restore(sup, name, was_running, cb)
  end)
end

-- The new process of leaf `name` wired as its old one was (device ports, this group's connections, active
-- sets), its ancestors told (`restarted`), then run with its last `init` if it was running.
function M.restore(sup, name, was_running, cb)
  local ch = sup.children[name]
  wiring.devices(sup, function(ok, err)
    if not ok then M.failed(sup, name, was_running, err, cb) return end
    M.tail(sup, name, was_running, cb)
  end, ch.path)
end

-- The end of a restart of child `name` (a leaf's new process, or a sub-group's new supervisor with its subtree up):
-- this group's connections of it made again, the taps it remembers (of the leaf, or of every leaf of the subtree)
-- made again, the groups above told (`restarted`), then run again with its last `init` if it ran (unless its
-- group's expression aborted it meanwhile); its `restarted` line and cb(true) once that run is answered. cb(true) |
-- the restart failed (M.failed)
function M.tail(sup, name, was_running, cb)
  local ch = sup.children[name]
  wiring.rewire(sup, ch.path, function(ok, err)
    if not ok then M.failed(sup, name, was_running, err, cb) return end
    taps.retap(sup, ch, function()
      sup.rt.report({ type = "restarted", path = ch.path })
      -- done (said, answered) once its Run has been answered: on simulated time the next tick then finds its
      -- timers (a restart by hand while time is held is done before time moves on)
      M.run_again(sup, name, was_running, function()
        M.restarted_line(sup, ch)
        local note = child.restart(ch, "code")
        child.unmark(ch, "code")
        cb(true, note)
      end)
    end)
  end)
end

-- The group is being shut down (or `ch` was stopped for good): a restart in flight starts nothing more.
function M.stopping_all(sup, ch)
  return ch.state == "gone" or sup.shutdown_waiters ~= nil or sup.state == "stopping" or sup.state == "stopped"
end

-- The restart of leaf `name` failed: whatever process it has is ended and, if it was running, it ends
-- ABORTED with the reason (its group's algebra decides what follows). cb(nil, reason)
function M.failed(sup, name, was_running, reason, cb)
  local ch = sup.children[name]
  child.unmark(ch, "replacing", "code")
  local h = ch.handle
  ch.handle, ch.exit_reason = nil, reason
  child.set(ch, "exited")
  if h then h.kill("KILL") end
  sup:say("%s: restart failed: %s", ch.path, tostring(reason))
  -- (a restart by the group's policy escalates instead: M.recover)
  if was_running and not child.restart(ch, "policy") and sup:_runs(name) then
    if require("dca.supervisor.fleet").owns(sup, name) then
      require("dca.supervisor.fleet").ended(sup, name, "aborted", reason)
    else
      sup.cause = sup.cause or { path = ch.path, reason = reason }
      sup:_feed(name, "aborted", reason)
    end
  end
  cb(nil, reason)
end

-- A leaf below this group was restarted (the `restarted` event of a child group): this group's own
-- connections of it are made again, and the event goes on up.
function M.leaf_restarted(sup, path)
  if type(path) ~= "string" then return end
  wiring.rewire(sup, path, function(ok, err)
    if not ok then sup:say("%s: reconnecting restarted %s: %s", sup.path, path, tostring(err)) end
    sup.rt.report({ type = "restarted", path = path })
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
-- T seconds, a sliding window on simulated time or rt.now(): M.policy_now) the group escalates: it stops
-- its running children (LIFO, the algebra's abort) and ends ABORTED with a reason that says so and names the
-- fault that exceeded it, its outcome's path the first cause (a leaf); the parent's policy then applies to it
-- as a `crash` of that child.
-- Faults that arrive while a restart runs wait for it, in order.

--- Whether this group's policy restarts a fault of `kind` now (it runs, and is not being stopped).
function M.policy_takes(sup, kind)
  local pol = sup.spec.supervision
  return pol ~= nil and pol.on ~= nil and pol.on[kind] == true and sup.state == "running" and not sup.escalated
    and sup.shutdown_waiters == nil
end

--- A fault of the children `names` (all ended by it), `how` it ended ("exit" | "aborted" | "escalated"), its
--- kind and reason; `cause` = { path, reason } of the first cause (a sub-group's outcome names its leaf).
function M.fault(sup, names, how, kind, reason, cause)
  local first = sup.children[names[1]]
  local f = { names = names, how = how, kind = kind, reason = reason, at = sup.event_at,
              cause = cause or { path = first.path, reason = reason } }
  f.last = how == "exit" and sformat("%s %s", first.name, reason) or sformat("%s %s: %s", first.name, how, reason)
  for _, n in ipairs(names) do child.mark(sup.children[n], { fault = true }) end
  sup.rt.defer(function() M.recover(sup, f) end)
end

--- The host a child restarts on after fault `f` (nil: the host it had): after its host was lost, the next of its
--- hosts (dca.supervisor.failover: a leaf's standby hosts, or its group's when it ran on the group's host; a
--- sub-group's host { } list), and a sub-group moves with the part of its subtree that ran on the lost host.
function M.host(sup, ch, f)
  if not f or f.kind ~= "lost" then return nil end
  local faulted = false
  for _, n in ipairs(f.names or {}) do faulted = faulted or n == ch.name end
  if not faulted then return nil end
  ch.failover_hosts = ch.failover_hosts or failover.hosts(ch.spec, sup.spec)
  local to = failover.next_host(ch.failover_hosts, ch.host)
  if to and ch.kind == "group" then ch.spec.spec = failover.moved(ch.spec.spec, ch.host, to) end
  return to
end

-- The children a restart after fault `f` takes down and starts again, in start order (those with a process
-- or a fault: never started ones, or those already stopped for good, are left alone).
function M.plan(sup, f)
  local order, faulted = {}, {}
  for _, c in ipairs(sup.spec.children) do order[#order + 1] = c.name end
  for _, n in ipairs(f.names) do faulted[n] = true end
  local out = {}
  for _, name in ipairs(policy.plan(sup.spec.supervision.strategy, order, faulted)) do
    local st = sup.children[name].state
    if faulted[name] or not (st == "new" or st == "failed" or st == "gone" or st == "starting") then
      out[#out + 1] = name
    end
  end
  return out, faulted
end

--- Applies the policy to fault `f`: within the intensity, the strategy's restart; past it, escalation.
function M.recover(sup, f)
  if sup.recovering then
    local q = sup.recovering.queue
    q[#q + 1] = f
    return
  end
  if not M.policy_takes(sup, f.kind) then M.unfault(sup, f) return end
  local pol = sup.spec.supervision
  local now = M.policy_now(sup, f.at)
  sup.restart_times = policy.window(sup.restart_times or {}, now, pol.within)
  if #sup.restart_times >= pol.intensity then M.escalate(sup, f, policy.exceeded(pol, f.last)) return end
  sup.restart_times[#sup.restart_times + 1] = now
  sup.restarts_total = (sup.restarts_total or 0) + 1
  local plan, faulted = M.plan(sup, f)
  local rec = { queue = {}, plan = plan, running = {}, started = {}, f = f }
  sup.recovering, sup.recovery_at = rec, f.at
  sup.restarting_below = sup.restarting_below or {}
  for _, name in ipairs(plan) do
    local ch = sup.children[name]
    rec.running[name] = sup:_runs(name)
    child.mark(ch, { replacing = true, policy = true })
    ch.restarts = (ch.restarts or 0) + 1
    if faulted[name] then
      child.mark(ch, { note = sformat(" %d/%d in %g s", #sup.restart_times, pol.intensity, pol.within) })
    end
    sup.restarting_below[ch.path] = (sup.restarting_below[ch.path] or 0) + 1
  end
  sup:say("%s: %s after %s: restarting %s (%d/%s)", sup.path, pol.strategy, f.last, concat(plan, ", "),
    #sup.restart_times, policy.budget(pol))
  local down = {}
  for k = #plan, 1, -1 do down[#down + 1] = plan[k] end
  async.each_in_order(down, function(name, _, next)
    M.take_down(sup, name, rec.running[name], function() if sup.recovering == rec then next() end end)
  end, function() M.bring_up_all(sup, rec) end)
end

-- The children of the restart `rec` started anew in start order (after their take-down); a failure escalates.
function M.bring_up_all(sup, rec)
  async.each_in_order(rec.plan, function(name, _, next)
    rec.started[name] = true
    M.bring_up(sup, name, rec.running[name], function(ok, err)
      if sup.recovering ~= rec then return end
      if not ok and sup.state ~= "running" then M.recovered(sup, rec) return end  -- stopped or aborted meanwhile
      if not ok then M.escalate(sup, rec.f, sformat("restart of %s failed: %s", name, tostring(err))) return end
      next()
    end)
  end, function() M.recovered(sup, rec) end)
end

-- The restart after `rec` is over: the children's marks cleared, the faults that waited handled in order.
function M.recovered(sup, rec)
  sup.recovering, sup.recovery_at = nil, nil
  M.unmark(sup, rec)
  for _, f in ipairs(rec.queue) do M.recover(sup, f) end
end

-- The faulted children of `f` are no longer waiting for a restart (it was not made).
function M.unfault(sup, f)
  for _, n in ipairs(f.names) do
    child.unmark(sup.children[n], "fault", "pending")
  end
end

function M.unmark(sup, rec)
  for _, name in ipairs(rec.plan) do
    local ch = sup.children[name]
    child.unmark(ch, "policy", "note", "fault", "pending")
    local path = ch.path
    local n = (sup.restarting_below[path] or 1) - 1
    sup.restarting_below[path] = n > 0 and n or nil
  end
end

-- Stops child `name` for a restart and ends its process (a sub-group: its subtree shut down first). cb()
function M.take_down(sup, name, was_running, cb)
  local ch = sup.children[name]
  child.set(ch, "restarting")
  local old = ch.handle
  if not old then cb() return end
  sup:say("%s: stopping to restart", ch.path)
  local function ended(ok, err)
    if not ok then sup:log("%s: end of %s: %s", sup.path, ch.path, tostring(err)) end
    if ch.handle == old then ch.handle = nil end
    cb()
  end
  local function kill() old.kill("TERM", ended) end
  if ch.kind == "group" then
    old.request({ type = "shutdown" }, sup.timeouts.shutdown, kill)
  elseif was_running then
    old.request({ type = "stop" }, sup.timeouts.stop, kill)
  else
    kill()
  end
end

-- Starts child `name` anew (after M.take_down), on the host M.host picks. cb(true) | cb(nil, reason)
function M.bring_up(sup, name, was_running, cb)
  local ch = sup.children[name]
  if M.stopping_all(sup, ch) then child.unmark(ch, "replacing") cb(nil, ch.path .. ": stopped while restarting") return end
  local host = sup:restart_host(ch, sup.recovering and sup.recovering.f)
  local function go()
    if ch.kind == "leaf" then M.respawn(sup, name, was_running, cb) return end
    M.respawn_group(sup, name, was_running, cb)
  end
  if not (host and host ~= ch.host) then go() return end
  local from = ch.host
  sup:say("%s: moves from host %s to host %s", ch.path, tostring(from), tostring(host))
  ch.spec = setmetatable({ host = host }, { __index = ch.spec })
  ch.host = host
  if not sup.rt.fenced then go() return end
  -- fencing (docs/supervision.md): the old host's leases lapse first, so the old instance has stopped
  sup.rt.fenced(from, function(waited)
    if waited then sup:say("%s: host %s fenced (waited %.2f s: fence + margin after its last renewal)", ch.path,
                           tostring(from), waited) end
    if M.stopping_all(sup, ch) then child.unmark(ch, "replacing") cb(nil, ch.path .. ": stopped while restarting") return end
    go()
  end)
end

-- A fresh supervisor of the sub-group `name`, configured with its spec (its subtree started and wired), then the
-- tail every restart shares (M.tail).
function M.respawn_group(sup, name, was_running, cb)
  local ch = sup.children[name]
  local answered = false
  local function failed(err)
    if answered then return end
    answered = true
    M.failed(sup, name, was_running, err, cb)
  end
  local timer = sup.rt.after(sup.timeouts.spawn + sup.timeouts.configure, function()
    failed(sformat("%s (supervisor on host %s) did not start within %gs", ch.path, tostring(ch.host),
      sup.timeouts.spawn + sup.timeouts.configure))
  end)
  sup.rt.spawn(ch.spec, function(handle, err, how)
    if answered then if handle then handle.kill("KILL") end return end
    if not handle then timer:cancel() failed(child.start_error(ch, err, how)) return end
    ch.handle = handle
    handle.request(sup:_configure_msg(ch), sup.timeouts.configure, function(reply, rerr)
      timer:cancel()
      if answered then return end
      local ok, why = async.outcome(reply, rerr)
      if not ok then failed(why) return end
      if M.stopping_all(sup, ch) then answered = true child.unmark(ch, "replacing") cb(nil, ch.path .. ": stopped") return end
      answered = true
      child.unmark(ch, "replacing")
      child.set(ch, "inactive")
      sup:_watch(name, handle)
      M.tail(sup, name, was_running, cb)
    end)
  end)
end

-- A child started anew runs with its last init if it ran (or its run was asked for meanwhile) and the
-- expression still runs it. done() once that run has been answered (or has failed); at once if there is none.
function M.run_again(sup, name, was_running, done)
  local ch = sup.children[name]
  local pending = child.restart(ch, "pending")
  child.unmark(ch, "pending", "fault", "policy")
  local acks = async.join(function() done() end)
  if (was_running or pending) and sup:_runs(name) then
    local outer = sup.run_acks
    sup.run_acks = acks   -- (Sup:_start_child joins the answer to its `run` here)
    sup:_start_child(name, ch.init)
    sup.run_acks = outer
  end
  acks.close()
end

function M.restarted_line(sup, ch)
  local pid, code = ch.handle and ch.handle.pid, child.restart(ch, "code")
  sup:say("%s: restarted%s%s%s", ch.path, child.restart(ch, "note") or "", pid and sformat(" (pid %s)", tostring(pid)) or "",
    code and ": " .. code or "")
end

--- Past the restart intensity: the running children stopped (LIFO), the group ended ABORTED with `reason`, its
--- outcome naming the first cause's path; the parent's policy (or algebra) takes it from there.
function M.escalate(sup, f, reason)
  local rec = sup.recovering
  sup.recovering, sup.recovery_at = nil, f.at
  if rec then M.unmark(sup, rec) end
  -- the faults that waited for the restart are not restarted either: their children no longer wait for one
  M.unfault(sup, f)
  for _, q in ipairs(rec and rec.queue or {}) do M.unfault(sup, q) end
  if sup.state ~= "running" then sup.recovery_at = nil return end  -- aborted or stopped meanwhile: no outcome
  sup.escalated = true
  sup:say("%s: %s", sup.path, reason)
  sup.cause = { path = f.cause.path, reason = reason }
  if sup.run and sup.state == "running" then
    sup.state = "aborting"
    sup.run:abort()
    require("dca.supervisor.fleet").stop_all(sup)   -- (its template's instances too)
  end
  sup.state = "aborted"
  sup.outcome = { status = "aborted", path = f.cause.path, reason = reason, escalated = true }
  sup:say("%s: aborted (%s: %s)", sup.path, f.cause.path, reason)
  sup.recovery_at = nil
  sup:_report({ type = "aborted", path = f.cause.path, reason = reason, escalated = true, now = now_ns(f.at) })
end

--- Restarts the process at `path`: a group's expression is aborted and started again (its latest event
--- actions take effect); a leaf is started anew from what is on disk now, while everything else runs
--- (M.leaf, done by the leaf's own group). cb(true[, note]) | cb(nil, reason)
function M.manual(sup, path, cb, opts)
  if path == sup.path then
    sup:abort(function()
      local ok, err = sup:run_expr(sup.last_init)
      cb(ok, err)
    end)
    return
  end
  local ch = sup:_via(path)
  -- (the breaks its leaves see while `path` is replaced are expected: M.restarting_peer)
  sup.restarting_below = sup.restarting_below or {}
  sup.restarting_below[path] = (sup.restarting_below[path] or 0) + 1
  local function finish(ok, err)
    local n = sup.restarting_below[path] - 1
    sup.restarting_below[path] = n > 0 and n or nil
    cb(ok, err)
  end
  if ch and ch.kind == "leaf" then M.leaf(sup, ch.name, finish, opts) return end
  local msg = { type = "restart", path = path, own_process = opts and opts.own_process or nil }
  sup:_forward(path, msg, function(r, err)
    if not r then finish(nil, err) return end
    -- a leaf below: this group's connections of it are made again before the answer (the `restarted` event
    -- does the same for the groups above one that restarts a leaf by itself; a connection made twice is one)
    wiring.rewire(sup, path, function(ok, werr) finish(ok, ok and r.note or werr) end)
  end)
end

-- The path of the process being restarted through this group that the data peer `peer` ("PATH.port") is
-- part of, or nil.
function M.restarting_peer(sup, peer)
  if type(peer) ~= "string" then return nil end
  for path in pairs(sup.restarting_below or {}) do
    if peer:sub(1, #path + 1) == path .. "." then return path end
  end
end

-- The time of the restart window: on simulated time (rt.on_sim_time()), the simulated time of the fault's event
-- (`at`; without one, the latest seen), else rt.now() (the memory runtime's simulated time, or the wall clock).
function M.policy_now(sup, at)
  if not (sup.rt.on_sim_time and sup.rt.on_sim_time()) then return sup.rt.now() end
  sup.sim_seen = math.max(sup.sim_seen or 0, at or 0)
  return sup.sim_seen
end

return M
