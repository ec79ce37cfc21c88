-- dca.clients.world: a run in simulated time (`dca run FILE --sim WORLD`): the world process, started
-- through a host's daemon before the tree (its nodes, on the simulated clock, subscribe to it when they
-- start), time started when the root runs, progress lines stamped with the simulated time, and the summary
-- read from the world at the end (ARCHITECTURE.md, "Time" and "The robot: device ports").
--
--   local sim = require "dca.clients.world"
--   local w = sim.new{ daemon = ADDR, host = NAME, key = FILE, world = "door", seed = N, door_width = W,
--                      record = FILE, jammed = true, wait = S }   -- jammed: the handle's latch never releases
--   w:start(function(ok, err) end)     -- spawn `dca sim --serve`, wait until `world` is registered, connect
--   w:go(cb)                           -- time starts flowing
--   w:stamp(line, function(t, line) end, at) -- calls back in the order of the calls, with the world's time
--                                      -- (when it answered: at or after the event), or `at` when given
--   w:summary(cb(lines))               -- "door opened to NN.N deg", times, the steps, and with o.periods
--                                      -- (leaf paths, e.g. M.period_leaves(spec)) the control periods they
--                                      -- achieved (their nodes' `stats`, asked before the tree stops):
--     MotionControl period PATH: nominal 1.000 ms; sim n N p50 .. ms p99 .. ms max .. ms;
--       wall n N p50 .. ms p99 .. ms p999 .. ms max .. ms        (one line: intervals between MainCalc calls)
--   o.realtime: the world paces simulated time to the wall clock (`dca sim --serve --realtime`); the nodes
--   stay in lock-step with it, so a wall interval is then the real control period
--   w:stop(cb)                         -- `exit` to the world, then waits for its exit (SIGKILL after a grace)
--   w.on_lost = function(reason) end   -- the world exited by itself (every node on its clock stops)
local core = require "dca.core"
local srt = require "dca.supervisor.net"

local M = {}

local ipairs, pairs, tostring, sformat, tonumber = ipairs, pairs, tostring, string.format, tonumber
local concat = table.concat

local W = {}
W.__index = W

--- The argv of the world process for options `o` (see the header).
function M.argv(o)
  local argv = { "dca", "sim", "--serve", "--daemon", o.daemon, "--host", o.host, "--world", o.world or "door" }
  if o.key then argv[#argv + 1] = "--key" argv[#argv + 1] = o.key end
  if o.seed then argv[#argv + 1] = "--seed" argv[#argv + 1] = tostring(o.seed) end
  if o.door_width then argv[#argv + 1] = "--door-width" argv[#argv + 1] = tostring(o.door_width) end
  if o.record then argv[#argv + 1] = "--record" argv[#argv + 1] = o.record end
  if o.jammed then argv[#argv + 1] = "--jammed" end
  if o.realtime then argv[#argv + 1] = "--realtime" end
  return argv
end

--- The leaves whose control periods the summary reports: those of every group of type `group_type`
--- (default "MotionControl", the paper's motion controller) in `spec`, in declaration order.
function M.period_leaves(spec, group_type)
  group_type = group_type or "MotionControl"
  local list = {}
  require("dca.supervisor.spec").walk(spec, function(n)
    if n.kind == "group" and n.type == group_type then
      for _, c in ipairs(n.spec.children) do
        if c.kind == "leaf" then list[#list + 1] = c.path end
      end
    end
  end)
  return list
end

local function ms(us) return (tonumber(us) or 0) / 1000 end

--- The summary line of one leaf's period figures (an `intervals` entry of its node's `stats` reply).
function M.period_line(path, iv)
  local c, w = iv.clock or {}, iv.wall or {}
  return sformat("MotionControl period %s: nominal %.3f ms; sim n %d p50 %.3f ms p99 %.3f ms max %.3f ms; "
    .. "wall n %d p50 %.3f ms p99 %.3f ms p999 %.3f ms max %.3f ms", path, (tonumber(iv.period_s) or 0) * 1000,
    tonumber(c.n) or 0, ms(c.p50_us), ms(c.p99_us), ms(c.max_us), tonumber(w.n) or 0, ms(w.p50_us), ms(w.p99_us),
    ms(w.p999_us), ms(w.max_us))
end

--- Asks each leaf of o.periods for its node's stats (found through the daemon; one at a time, each bounded)
--- and calls back with the lines: one per periodic timer of the leaf, or why there is none.
function W:periods(cb)
  local paths, lines, i = self.o.periods or {}, {}, 0
  local function next_leaf()
    i = i + 1
    local path = paths[i]
    if not path then cb(lines) return end
    local function say(line) lines[#lines + 1] = line next_leaf() end
    if not self.dch then say(sformat("MotionControl period %s: no daemon to ask", path)) return end
    self.dch:request({ type = "lookup", name = path, wait_ms = 2000 }, 5, function(lr, lerr)
      local ep = lr and lr.type ~= "error" and (lr.endpoints or lr)
      if not ep or not ep.control then
        say(sformat("MotionControl period %s: not found (%s)", path, tostring(lr and lr.reason or lerr)))
        return
      end
      core.connect(ep.control, srt.key_opts(self.o.key), function(ch, cerr)
        if not ch then say(sformat("MotionControl period %s: %s", path, tostring(cerr))) return end
        ch:on_message(function() end)
        ch:request({ type = "stats" }, 5, function(r, serr)
          ch:close()
          if not r or r.type == "error" then
            say(sformat("MotionControl period %s: no stats (%s)", path, tostring(r and r.reason or serr)))
            return
          end
          local found = false
          for _, iv in ipairs(r.intervals or {}) do
            if iv.name == path or #(r.intervals) == 1 then
              found = true
              lines[#lines + 1] = M.period_line(path, iv)
            end
          end
          if not found then lines[#lines + 1] = sformat("MotionControl period %s: it ran no periodic timer", path) end
          next_leaf()
        end)
      end)
    end)
  end
  next_leaf()
end

function M.new(o)
  return setmetatable({ o = o, steps = {}, order = {}, pending = {}, t_last = 0 }, W)
end

--- Spawns the world through the daemon at o.daemon and connects to it once it has registered.
function W:start(cb)
  local o = self.o
  local done = false
  local function finish(ok, err)
    if done then return end
    done = true
    cb(ok, err)
  end
  core.connect(o.daemon, srt.key_opts(o.key), function(dch, err)
    if not dch then finish(false, sformat("the daemon of host %s at %s: %s", o.host, o.daemon, tostring(err))) return end
    self.dch = dch
    dch:on_message(function(msg)
      if msg.type == "exit" and msg.child == self.child then
        self.exited = srt.describe_exit(msg, o.host)
        if not self.stopping and done and self.on_lost then self.on_lost("the world " .. self.exited) end
        local ws = self.exit_waiters or {}
        self.exit_waiters = nil
        for _, w in ipairs(ws) do w() end
        finish(false, "the world (dca sim --serve) " .. self.exited)
      end
    end)
    dch:request({ type = "spawn", argv = M.argv(o), name = "world" }, 10, function(r, serr)
      if not r or r.type == "error" then
        finish(false, sformat("could not start the world on host %s: %s", o.host, tostring(r and r.reason or serr)))
        return
      end
      self.child, self.pid = r.child, r.pid
      local wait_ms = math.floor((o.wait or 60) * 1000)
      dch:request({ type = "lookup", name = "world", wait_ms = wait_ms }, wait_ms / 1000 + 2, function(lr, lerr)
        local ep = lr and lr.type ~= "error" and (lr.endpoints or lr)
        if not ep or not ep.control then
          finish(false, sformat("the world did not register within %gs: %s", o.wait or 60,
            tostring(lr and lr.reason or lerr)))
          return
        end
        core.connect(ep.control, srt.key_opts(o.key), function(ch, cerr)
          if not ch then finish(false, sformat("the world at %s: %s", ep.control, tostring(cerr))) return end
          self.ch = ch
          ch:on_message(function() end)
          finish(true)
        end)
      end)
    end)
  end)
end

--- A request to the world. cb(reply | nil, err)
function W:request(msg, timeout, cb)
  if not self.ch then cb(nil, "the world is not connected") return end
  self.ch:request(msg, timeout or 10, function(r, err)
    if r and r.type == "error" then cb(nil, r.reason) else cb(r, err) end
  end)
end

function W:go(cb) self:request({ type = "go" }, 10, cb or function() end) end
--- Time stops after the current tick. cb(reply {now} | nil, err)
function W:hold(cb) self:request({ type = "hold" }, 10, cb or function() end) end

-- A transition line ("main.a: running") --> path, word
local function transition(line)
  return tostring(line):match("^(%S+): (%a+)")
end
local ENDS = { done = true, aborted = true, stopped = true, exited = true, lost = true }

--- Asks the world's time for `line`; fn(t, line) is called in the order of the stamp calls (replies on one
--- channel come in order). Transitions are remembered as the steps of the run.
function W:stamp(line, fn, at)
  local entry = { line = line, fn = fn, at = at }
  self.pending[#self.pending + 1] = entry
  local function flush()
    while self.pending[1] and self.pending[1].t do
      local e = table.remove(self.pending, 1)
      -- a node's clock may lag the world's by up to a sync period (it is advanced when due): a line is
      -- never stamped before the one said before it
      e.t = math.max(e.t, self.t_flushed or 0)
      self.t_flushed = e.t
      local path, word = transition(e.line)
      if word == "running" then
        if not self.steps[path] then self.order[#self.order + 1] = path end
        self.steps[path] = { start = e.t }
      elseif word and ENDS[word] and self.steps[path] and not self.steps[path].stop then
        self.steps[path].stop, self.steps[path].how = e.t, word
      end
      e.fn(e.t, e.line)
    end
  end
  if not self.ch then entry.t = self.t_last flush() return end
  -- the world's time when the status is answered: at or after the line's event (the world runs on);
  -- a leaf's event that carries its own time (`at`) is stamped with that
  self:request({ type = "status" }, 10, function(r)
    entry.t = entry.at or (r and tonumber(r.t)) or self.t_last
    self.t_last = math.max(self.t_last, entry.t)
    flush()
  end)
end

--- The end-of-run summary, from the world's status. cb({ lines }, status)
function W:summary(wall, cb)
  self:request({ type = "status" }, 10, function(r, err)
    local lines = {}
    if not r then cb({ "the world did not answer its status: " .. tostring(err) }) return end
    if r.door_angle then lines[#lines + 1] = sformat("door opened to %.1f deg", math.deg(tonumber(r.door_angle) or 0)) end
    local t = tonumber(r.t) or 0
    lines[#lines + 1] = sformat("simulated %.3f s in %.3f s of wall-clock time", t, wall)
    if tonumber(r.rounds) and r.rounds > 0 then
      lines[#lines + 1] = sformat("lock-step: %d rounds, %d advances; wall time per round p50 %.0f us, p99 %.0f us, max %.0f us",
        r.rounds, tonumber(r.advances) or 0, tonumber(r.round_p50_us) or 0, tonumber(r.round_p99_us) or 0,
        tonumber(r.round_max_us) or 0)
    end
    for _, d in ipairs(r.dropped or {}) do lines[#lines + 1] = "dropped from the clock: " .. tostring(d) end
    if #self.order > 0 then
      lines[#lines + 1] = "steps (simulated time, s):"
      for _, path in ipairs(self.order) do
        local s = self.steps[path]
        lines[#lines + 1] = sformat("  %8.3f - %s  %s%s", s.start, s.stop and sformat("%8.3f", s.stop) or "     ...",
          path, s.how and ("  " .. s.how) or "")
      end
    end
    self:periods(function(plines)
      for _, l in ipairs(plines) do lines[#lines + 1] = l end
      cb(lines, r)
    end)
  end)
end

--- Ends the world: `exit`, then SIGTERM and SIGKILL through its daemon if it lingers. cb() once it exited
--- (or after the last bound).
function W:stop(cb)
  cb = cb or function() end
  self.stopping = true
  if not self.child or self.exited or not self.dch then cb() return end
  local called = false
  local function done() if not called then called = true cb() end end
  self.exit_waiters = self.exit_waiters or {}
  self.exit_waiters[#self.exit_waiters + 1] = done
  if self.ch then self.ch:request({ type = "exit" }, 5, function() end) end
  local grace = self.o.stop_grace or 5
  core.after(grace, function()
    if self.exited then return end
    self.dch:request({ type = "kill", child = self.child, signal = "TERM" }, 5, function() end)
    core.after(grace, function()
      if self.exited then return end
      self.dch:request({ type = "kill", child = self.child, signal = "KILL" }, 5, function() end)
      core.after(grace, done)
    end)
  end)
end

function W:close()
  if self.ch then self.ch:close() end
  if self.dch then self.dch:close() end
end

return M
