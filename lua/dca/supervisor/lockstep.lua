-- dca.supervisor.lockstep: the network runtime's part in simulated time (ARCHITECTURE.md "Time"). On simulated
-- time a supervisor takes part in the clock master's barrier. It counts the events it received (its leaves'
-- done/aborted, its groups' outcomes, a leaf that ended unasked) and sent (its outcome to its parent), and
-- answers `quiesce {t}` with them once it has nothing left to do: no request of its own unanswered (pings
-- aside), nothing deferred.
--
-- The functions here are methods of the runtime of dca.supervisor.net, which binds them with its own as
-- rt.name(...): busy_while, on_sim_time, join_clock, leave_clock and the barrier's steps. Their state is rt.ls.
local Net = {}

local core = require "dca.core"
local async = require "dca.async"

local ipairs, pairs, pcall, type, error, tonumber = ipairs, pairs, pcall, type, error, tonumber
local sformat = string.format


--- `fn` wrapped so that the supervisor is busy until it has run (and its own requests made meanwhile).
function Net:busy_while(fn)
  local ls = self.ls
  ls.pending = ls.pending + 1
  return function(...)
    local ok, err = true, nil
    if fn then ok, err = pcall(fn, ...) end
    ls.pending = ls.pending - 1
    if ls.pending == 0 and #ls.waiters > 0 then
      local ws = ls.waiters
      ls.waiters = {}
      for _, w in ipairs(ws) do w() end
    end
    if not ok then error(err, 0) end
  end
end

-- An event from a started process: in lock-step a leaf's end waits for the barrier (its node may be one of
-- several that ended in the same round); everything else is handled at once. A group's outcome counts.
function Net:_child_event(p, msg)
  local ls, ends = self.ls, msg.type == "done" or msg.type == "aborted"
  if ends and p.kind == "leaf" and ls.joined then
    ls.per[p.path] = (ls.per[p.path] or 0) + 1
    ls.queue[#ls.queue + 1] = { now = tonumber(msg.now) or 0, name = p.name, msg = msg }
    return
  end
  self.sup:child_message(p.name, msg)
  if ends then ls.received = ls.received + 1 end
end

-- True when every event of this supervisor's leaves that the master counted (`events`, `lost`) is here.
function Net:_arrived(q)
  local ls = self.ls
  for path, n in pairs(q.events or {}) do
    if self.my_leaves[path] and (ls.per[path] or 0) < n then return false end
  end
  for path, n in pairs(q.lost or {}) do
    if self.my_leaves[path] and (ls.exited[path] or 0) < n then return false end
  end
  return true
end

-- `quiesce {t, events, lost}` from the clock master: once the counted events of its leaves are here, they are
-- handled in (time, name) order, whatever order they came in; answered once idle, with the counts.
function Net:_quiesce(ch, id, q)
  local ls = self.ls
  if not self._arrived(q) then
    self._end_lost(q.lost, q.why)
    core.after(0.0005, function() self._quiesce(ch, id, q) end)
    return
  end
  local queue = ls.queue
  ls.queue = {}
  table.sort(queue, function(a, b) if a.now ~= b.now then return a.now < b.now end return a.name < b.name end)
  for _, e in ipairs(queue) do
    -- an exit (a node lost at tick q.t) happened at the barrier's tick: the reactions carry that time
    local saved = self.sup.event_at
    if e.exit and tonumber(q.t) then self.sup.event_at = q.t / 1e9 end
    if e.exits then self.sup:children_exit(e.exits, e.exit, e.lost)
    elseif e.exit then self.sup:child_exit(e.name, e.exit, e.lost)
    else self.sup:child_message(e.name, e.msg) end
    self.sup.event_at = saved
    ls.received = ls.received + (e.exits and #e.exits or 1)
  end
  local function answer() ch:reply(id, { received = ls.received, sent = ls.sent }) end
  if ls.pending == 0 then answer() else ls.waiters[#ls.waiters + 1] = answer end
end

-- The clock master dropped these leaves' nodes (`lost`): one whose exit has not come within a grace
-- (opts.lost_grace, default 1 s: a crashed process's exit, with its own signal, comes first; the master closed
-- the clock channel, which stops a node that still reads it) stalled rather than crashed, and is killed, once,
-- so that its exit comes and the barrier waiting for it ends. A shared node is killed whole: the master drops
-- a process. If that exit does not come either (its daemon gone) within opts.stop_grace (default 5 s) of the
-- SIGKILL, it is taken as arrived, said in the log (leaf, host), and the node's end told as lost: the barrier
-- is bounded. `why` (by leaf): the master's reason, which its exit then carries before the signal that ended it.
function Net:_end_lost(lost, why)
  local ls = self.ls
  for path, n in pairs(lost or {}) do
    if self.my_leaves[path] and (ls.exited[path] or 0) < n and (ls.ended[path] or 0) < n then
      ls.ended[path] = n
      core.after(self.opts.lost_grace or 1, function()
        if (ls.exited[path] or 0) >= n or self.closing then return end
        local procs = {}
        for _, p in pairs(self.by_child) do
          local hit = p.path == path
          for leaf in pairs(p.leaves or {}) do hit = hit or leaf.path == path end
          if hit and not p.exited and not p.ended then
            procs[#procs + 1] = p
            p.kill_why = why and why[path] and sformat("dropped by the clock master: %s", tostring(why[path]))
            local d = p.daemon or p.dc
            d:kill(p.child, "KILL")
          end
        end
        self._give_up_lost(path, n, procs)
      end)
    end
  end
end

-- The exit of the dropped leaf `path` (the n-th the master counted) did not come within stop_grace of its
-- SIGKILL: each of `procs` still not ended ends as lost, and the count is made whole.
function Net:_give_up_lost(path, n, procs)
  local ls, grace = self.ls, self.opts.stop_grace or 5
  core.after(grace, function()
    if (ls.exited[path] or 0) >= n or self.closing then return end
    local host = procs[1] and procs[1].host or "?"
    local why = sformat("node lost on host %s: dropped by the clock master, no exit within %gs of SIGKILL", host, grace)
    self.log(sformat("%s: %s; its exit is taken as arrived", path, why))
    for _, p in ipairs(procs) do
      if not p.exited and not p.ended then p:exited_with(self, why, nil, true) p:gone() end
    end
    if (ls.exited[path] or 0) < n then ls.exited[path] = n end
  end)
end

--- Whether this supervisor takes part in the simulated clock (events then carry the simulated time, which a
--- supervision policy's restart window counts in).
function Net:on_sim_time() return self.ls.joined == true end

--- On simulated time (this host's daemon says so) with a world: subscribes to its clock as a supervisor.
--- cb(true) (also when there is nothing to join) | cb(nil, err)
function Net:join_clock(name, cb)
  self.daemon(self.own_host(), function(dc)
    if not dc then cb(true) return end
    dc:request({ type = "ping" }, 10, function(r)
      if not r or r.clock ~= "sim" then cb(true) return end
      self.world({ type = "clock", name = name, role = "supervisor" }, 10, function(rr, err, missing)
        if missing then cb(true) return end
        local ok, why = async.outcome(rr, err)
        if not ok then cb(nil, sformat("%s cannot join the simulated clock: %s", name, why)) return end
        self.ls.joined = true
        -- the counts so far are of processes before this supervisor (it is a restarted group's): already had
        for path, n in pairs(type(rr.lost) == "table" and rr.lost or {}) do
          self.ls.exited[path] = math.max(self.ls.exited[path] or 0, tonumber(n) or 0)
        end
        for path, n in pairs(type(rr.events) == "table" and rr.events or {}) do
          self.ls.per[path] = math.max(self.ls.per[path] or 0, tonumber(n) or 0)
        end
        cb(true)
      end)
    end)
  end)
end
--- On the clock, leaves it in order (after shutdown): says its last counts (an event still queued is had: it
--- goes with it), so that the master does not take its closed channel for a lost host. cb() when done.
function Net:leave_clock(cb)
  local w, ls = self._world, self.ls
  if not (ls.joined and w and w.client and w.client:is_open()) then cb() return end
  local received = ls.received
  for _, e in ipairs(ls.queue) do received = received + (e.exits and #e.exits or 1) end
  ls.joined = false
  w.client:request({ type = "unclock", received = received, sent = ls.sent }, 2, function() cb() end)
end

return Net
