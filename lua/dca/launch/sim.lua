-- dca.launch.sim: a run in simulated time (`dca run FILE --sim WORLD`, a scenario with { sim = WORLD }): the
-- world process (dca.clients.world) started before the tree, progress lines stamped with the world's time,
-- the transitions kept as the steps of the run, and the end-of-run summary: the world's figures, the steps
-- and what the world's report hook (its descriptor's, dca.worlds) adds.
--
--   local sim = require "dca.launch.sim"
--   local s = sim.new(world_opts, spec)     -- world_opts: those of dca.clients.world.new
--   s.world                                 -- the dca.clients.world client
--   s:stamp(line, function(t, line) end, at) -- calls back in the order of the calls, with the world's time
--                                           -- (when it answered: at or after the event), or `at` when given
--   s:summary(wall, cb(lines, status))      -- simulated and wall time, lock-step figures, steps, the hook's
local world_client = require "dca.clients.world"
local worlds = require "dca.worlds"

local M = {}

local ipairs, tostring, sformat, tonumber, max = ipairs, tostring, string.format, tonumber, math.max

local S = {}
S.__index = S

function M.new(o, spec)
  local hook = worlds.descriptor(o.world).report
  return setmetatable({ world = world_client.new(o), hook = hook, leaves = spec and hook.leaves(spec) or {},
                        steps = {}, order = {}, pending = {}, t_last = 0 }, S)
end

-- A transition line ("main.a: running") --> path, word
local function transition(line)
  return tostring(line):match("^(%S+): (%a+)")
end
local ENDS = { done = true, aborted = true, stopped = true, exited = true, lost = true }

-- Remembers a transition as a step: "running" starts one, an end word ends it.
function S:_step(line, t)
  local path, word = transition(line)
  if word == "running" then
    if not self.steps[path] then self.order[#self.order + 1] = path end
    self.steps[path] = { start = t }
  elseif word and ENDS[word] and self.steps[path] and not self.steps[path].stop then
    self.steps[path].stop, self.steps[path].how = t, word
  end
end

-- With --record FILE.mcap: the line, at its time, to the recording's channel /dca/events (the world writes it;
-- the reply is not waited for); a line process `output` wrote to its stderr ("PATH: text") to /dca/log instead.
function S:_note(line, t, output)
  local file = self.world.o.record
  if not (file and file:match("%.mcap$") and self.world:connected()) then return end
  if output then
    self.world:request({ type = "note", channel = "log", t = t, path = output,
                         line = tostring(line):sub(#output + 3) }, 10, function() end)
    return
  end
  local path, word = transition(line)
  self.world:request({ type = "note", t = t, line = tostring(line), path = path or "", state = word or "",
                       fault = M.fault(line) }, 10, function() end)
end

--- Whether a line is a fault that triggers a black box besides a transition to `aborted` or `lost` (the world
--- takes those by their state): a leaf's crash ("P: exited: killed by SIGSEGV ...", "exited with code 3 ...")
--- and an escalation ("P: restart intensity 2 in 10 s exceeded; last: ...", dca.supervisor.policy).
function M.fault(line)
  line = tostring(line)
  local reason = line:match("^%S+: exited: (.*)")
  if reason then
    return reason:find("killed by SIG", 1, true) ~= nil or reason:find("exited with code [1-9]") ~= nil
  end
  return line:find("^%S+: restart intensity .- exceeded") ~= nil
end

-- Calls back the stamped lines in order, as far as they have their time.
function S:_flush()
  while self.pending[1] and self.pending[1].t do
    local e = table.remove(self.pending, 1)
    -- a node's clock may lag the world's by up to a sync period (it is advanced when due): a line is never
    -- stamped before the one said before it
    e.t = max(e.t, self.t_flushed or 0)
    self.t_flushed = e.t
    if not e.output then self:_step(e.line, e.t) end
    if not e.private then self:_note(e.line, e.t, e.output) end
    e.fn(e.t, e.line)
  end
end

--- Asks the world's time for `line`; fn(t, line) is called in the order of the stamp calls (replies on one
--- channel come in order). Transitions are remembered as the steps of the run; `output`: the line is one the
--- process of that path wrote to its stderr, no transition (recorded on /dca/log); `private`: never recorded
--- (a line that carries the monitor's token).
function S:stamp(line, fn, at, output, private)
  local entry = { line = line, fn = fn, at = at, output = output, private = private }
  self.pending[#self.pending + 1] = entry
  if not self.world:connected() then entry.t = self.t_last self:_flush() return end
  -- the world's time when the status is answered: at or after the line's event (the world runs on); a leaf's
  -- event that carries its own time (`at`) is stamped with that
  self.world:request({ type = "status" }, 10, function(r)
    entry.t = entry.at or (r and tonumber(r.t)) or self.t_last
    self.t_last = max(self.t_last, entry.t)
    self:_flush()
  end)
end

-- The summary's own lines from the world's status `r` (after the hook's head).
function S:_figures(r, wall, lines)
  lines[#lines + 1] = sformat("simulated %.3f s in %.3f s of wall-clock time (%.3f s since time started, "
    .. "%.3f s of it stepping the world)", tonumber(r.t) or 0, wall, tonumber(r.run_wall_s) or 0, tonumber(r.step_s) or 0)
  if tonumber(r.rounds) and r.rounds > 0 then
    lines[#lines + 1] = sformat("lock-step: %d rounds, %d advances; wall time per round p50 %.0f us, p99 %.0f us, "
      .. "max %.0f us; %d barriers", r.rounds, tonumber(r.advances) or 0, tonumber(r.round_p50_us) or 0,
      tonumber(r.round_p99_us) or 0, tonumber(r.round_max_us) or 0, tonumber(r.barriers) or 0)
    lines[#lines + 1] = sformat("lock-step wall time: rounds %.3f s, barriers %.3f s, the world's inputs %.3f s",
      tonumber(r.rounds_s) or 0, tonumber(r.barrier_s) or 0, tonumber(r.take_s) or 0)
  end
  for _, d in ipairs(r.dropped or {}) do lines[#lines + 1] = "dropped from the clock: " .. tostring(d) end
  -- one writer at a time on each command input (docs/safety.md): the second writers the world refused
  local inputs = {}
  for input in pairs(type(r.writers_refused) == "table" and r.writers_refused or {}) do inputs[#inputs + 1] = input end
  table.sort(inputs)
  for _, input in ipairs(inputs) do
    lines[#lines + 1] = sformat("second writer refused on %s: %d samples", input, tonumber(r.writers_refused[input]) or 0)
  end
  for _, w in ipairs(r.second_writers or {}) do lines[#lines + 1] = "  " .. tostring(w) end
  M.estop_lines(r, lines)
  if #self.order == 0 then return end
  lines[#lines + 1] = "steps (simulated time, s):"
  for _, path in ipairs(self.order) do
    local s = self.steps[path]
    lines[#lines + 1] = sformat("  %8.3f - %s  %s%s", s.start, s.stop and sformat("%8.3f", s.stop) or "     ...",
      path, s.how and ("  " .. s.how) or "")
  end
end

--- The emergency stop's lines of the summary (docs/safety.md) from the world's status `r`, added to `lines`.
function M.estop_lines(r, lines)
  local e = type(r.estop) == "table" and r.estop or {}
  if (tonumber(e.presses) or 0) == 0 then return end
  lines[#lines + 1] = sformat("emergency stop: pressed %d time%s, %d command samples kept from the robot while "
    .. "latched%s", e.presses, e.presses == 1 and "" or "s", tonumber(e.held_samples) or 0,
    e.latched and sformat("; still latched (by %s)", tostring(e.source)) or "")
  for _, l in ipairs(r.estop_log or {}) do lines[#lines + 1] = "  " .. tostring(l) end
end

--- The end-of-run summary, from the world's status. cb({ lines }, status)
function S:summary(wall, cb)
  self.world:request({ type = "status" }, 10, function(r, err)
    if not r then cb({ "the world did not answer its status: " .. tostring(err) }) return end
    local lines = self.hook.head(r)
    self:_figures(r, wall, lines)
    self.hook.tail(self.leaves, self.world.daemon, self.world.o.key, function(more)
      for _, l in ipairs(more) do lines[#lines + 1] = l end
      cb(lines, r)
    end)
  end)
end

return M
