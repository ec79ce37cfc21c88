-- dca.scenario: scripted test scenarios (`dca scenario FILE.lua`): start a system, drive it, assert.
--
--   local S = require "dca.scenario"
--   local sys = S.system("scripts/systems/test_compliant.dca", { root = "main" })
--   S.step("the tree comes up", function() sys:up() end)
--   S.step("hit ends the group", function()
--     sys:run()
--     sys:inject("main.motion.hit", "done", 2.5)
--     local out = sys:wait_outcome(10)
--     S.eq(out.type, "done")
--   end)
--   return S.finish()
--
-- Every wait has a timeout (seconds of the system's time). Steps are reported one line each
-- ("ok   2 hit ends the group (t=2.000)"); the first failing step ends the scenario and the system is stopped.
--
-- Faults: sys:kill(path, sig), sys:lose_host(host), sys:freeze(path) / sys:freeze_host(host) (SIGSTOP: sockets
-- stay open, the heartbeat finds the silence), sys:drop(path, set). Conditions: sys:wait(what, pred, t),
-- sys:wait_state(path, state, t), sys:wait_read(path, port, pred, t), sys:wait_outcome(t); sys:host(path).
-- In the real backend (wall clock) a timeout only bounds a hang (it is stretched, see scenario_real.bound) and
-- wait_state is met when the process has been in the state since the last run() (from the transition
-- lines, so a short state is never missed).
--
-- Simulated time with a world (real backend only): S.system(file, { sim = "door", seed = N, door_width = W,
-- jammed = true, world_host = NAME }) starts the daemons on the simulated clock and the world (`dca sim
-- --serve`, as `dca run --sim` does, through the daemon of world_host, default the first host name) before the
-- tree; run() sends the world `go` once the root's run has been answered. sys:world_status() is the world's
-- `status {}` (t, door_angle, base_pose, latched, ...), sys:world_read(port) its `read {port}` (the latest
-- base.cmd_vel / arm.cmd_qd it received, or a sensor output such as arm.q), sys:world_hold() / world_go()
-- stop and restart its time, sys:wait_world(what, pred(status), t) waits for a condition on its status.
--
-- Configuration: a system's config("key") parameters read the repository; S.system(file, { config = FILE,
-- set = { key = value } }) seeds it as `dca run --config FILE --set KEY=VALUE` does (default: FILE.config
-- beside the .dca file, when there is one). The memory backend reads the same values.
-- A scenario that only makes sense on some backends says so: S.backends = {"real"} (the CMake then makes
-- only those tests; another backend fails with a message saying so).
--
-- Backends: "memory" runs the tree in dca.supervisor.memory (simulated time, nodes whose behaviour follows
-- their type: Timer, Deadline, Crash, Constant...; other types run until an event is injected or they are
-- killed). The backend is chosen with `dca scenario --backend NAME` (default memory).
local spec_mod = require "dca.supervisor.spec"
local T = require "dca.testing"

local M = {}

local ipairs, pairs, type, tostring, sformat, pcall, xpcall = ipairs, pairs, type, tostring, string.format, pcall, xpcall
local traceback = debug.traceback

M.backend = "memory"
M.eq, M.ok, M.contains, M.show = T.eq, T.ok, T.contains, T.show

-- Behaviours of the built-in test controllers in the memory backend, after controllers/builtins (args: the
-- .dca arguments after the host, in the registry's parameter order). Values are scalars here.
local function num(v, d) return tonumber(v) or d end
M.behave = {
  Timer = function(n) n:after(num(n.args[1], 1), function() n:done("timeout") end) end,
  Deadline = function(n) n:after(num(n.args[1], 1), function() n:aborted("deadline of " .. tostring(n.args[1]) .. " s passed") end) end,
  Constant = function(n)
    local v = num(n.args[2], 0)
    local period = num(n.args[1], 0)
    if period > 0 then n:every(period, function() n:write("Out", v) end) else n:write("Out", v) end
  end,
  Gain = function(n)
    n.on_input = function(self, _, v) self:write("Out", num(self.args[1], 1) * num(v, 0)) end
  end,
  Sum = function(n)
    n.on_input = function(self) self:write("Out", num(self.ports.In1, 0) + num(self.ports.In2, 0)) end
  end,
  Threshold = function(n)
    local level, dir = num(n.args[1], 0), n.args[2] or "rising"
    local prev
    n.on_input = function(self, _, v)
      v = num(v, 0)
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
    local limit = math.tointeger(num(n.args[2], 0)) or 0
    n:every(num(n.args[1], 1), function(k)
      n:write("Count", k)
      if limit > 0 and k >= limit then n:done(k) end
    end)
  end,
  Crash = function(n)
    local ticks = num(n.args[1], 1)
    n:every(num(n.args[3], 0.001), function(k) if k >= ticks then n.c:kill(n.path, "SEGV") end end)
  end,
}

local steps = { n = 0, failed = 0, lines = {} }
local systems = {}

--- Loads, checks and builds the system in FILE (root opts.root or "main"). Errors stop the scenario.
function M.spec(file, root)
  local spec, err = require("dca.load").spec(file, { root = root })
  if not spec then error(err, 0) end
  return spec
end

local System = {}
System.__index = System

--- A system from a .dca file (or a ready spec with opts.spec), not started yet.
function M.system(file, opts)
  opts = opts or {}
  if M.backends then
    local fits = false
    for _, b in ipairs(M.backends) do fits = fits or b == M.backend end
    if not fits then
      error(sformat("this scenario runs on the backend(s) %s only (S.backends), not %s: run it with --backend %s",
        table.concat(M.backends, ", "), M.backend, M.backends[1]), 0)
    end
  end
  if opts.sim and M.backend ~= "real" then
    error("a system in simulated time with a world (sim = " .. tostring(opts.sim) .. ") needs --backend real", 0)
  end
  local spec = opts.spec or M.spec(file, opts.root)
  -- the configuration repository: opts.config (a defaults file; default FILE.config beside FILE.dca), then
  -- opts.set = { key = value } over it, as `dca run --config/--set`
  local cfg = require "dca.config"
  local cfile = opts.config or (file and cfg.defaults_file(file)) or nil
  if M.backend == "real" then
    local s = require("dca.scenario.real").system(spec, { file = file, root = opts.root, sim = opts.sim,
      seed = opts.seed, door_width = opts.door_width, jammed = opts.jammed, world_host = opts.world_host,
      record = opts.record, config = cfile, set = opts.set })
    s.commands, s.host = System.commands, System.host
    systems[#systems + 1] = s
    return s
  end
  local fake = require "dca.supervisor.memory"
  local behave = setmetatable(opts.behave or {}, { __index = M.behave })
  local repo = {}
  if cfile then
    local entries, cerr = cfg.read_file(cfile)
    if not entries then error(cerr, 0) end
    for _, e in ipairs(entries) do repo[e.key] = e.value end
  end
  for k, v in pairs(opts.set or {}) do repo[k] = v end
  local c = fake.cluster{ behave = behave, timeouts = opts.timeouts, heartbeat = opts.heartbeat or { 1, 5 },
                          config = repo }
  local s = setmetatable({ spec = spec, c = c, file = file, root = opts.root, backend = "memory" }, System)
  c:root(spec, { timeouts = opts.timeouts })
  systems[#systems + 1] = s
  return s
end

--- Starts, connects and confirms the whole tree (raises with the reason when the start fails).
function System:up(timeout)
  local ok, err = self.c:configure(self.c.t + (timeout or 30))
  if not ok then error("start failed: " .. tostring(err), 0) end
  return true
end

--- Like up(), but returns false, reason instead of raising.
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
  local ok, spec = pcall(M.spec, file or self.file, self.root)
  if not ok then return nil, tostring(spec) end
  local lines
  self.c.root_sup:update(spec, function(l) lines = l end)
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

--- The leaves' run and stop commands in the order their supervisors issued them ("main.a run",
--- "main.a stop"), optionally only those matching `pattern`. The same in every backend.
function System:commands(pattern)
  local leaf = {}
  spec_mod.walk(self.spec, function(n) if n.kind == "leaf" then leaf[n.path] = true end end)
  local out = {}
  for _, l in ipairs(self:transitions()) do
    local path, what = l:match("^(%S+): (%a+)$")
    local cmd = path and leaf[path] and ((what == "running" and path .. " run") or (what == "aborting" and path .. " stop"))
    if cmd and (not pattern or cmd:find(pattern)) then out[#out + 1] = cmd end
  end
  return out
end

--- The host name of the process at `path` (from the system's spec), or nil.
function System:host(path)
  local host
  spec_mod.walk(self.spec, function(n) if n.path == path then host = n.host end end)
  return host
end

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
      c.config[k] = v
      for _, w in ipairs(c.config_watchers) do
        if k == w.prefix or w.prefix == "" or k:sub(1, #w.prefix + 1) == w.prefix .. "." then
          w.events[#w.events + 1] = { key = k, value = v, origin = host }
        end
      end
    end
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

--- Runs one named step; its failure is reported with the reason and ends the scenario.
function M.step(name, fn)
  if steps.failed > 0 then return false end
  steps.n = steps.n + 1
  local ok, err = xpcall(fn, function(e)
    if type(e) == "string" and not e:find("traceback") then return traceback(e, 2) end
    return tostring(e)
  end)
  local t = systems[#systems] and systems[#systems]:now() or 0
  if ok then
    print(sformat("ok   %d %s (t=%.3f)", steps.n, name, t))
  else
    steps.failed = steps.failed + 1
    print(sformat("FAIL %d %s (t=%.3f)\n  %s", steps.n, name, t, tostring(err):gsub("\n", "\n  ")))
  end
  return ok
end

--- Ends the scenario: stops every system still up, prints the summary; returns the exit code.
function M.finish()
  for _, s in ipairs(systems) do
    if not s.stopped then
      local clean = s:stop()
      if not clean then
        steps.failed = steps.failed + 1
        print("FAIL processes left after stop: " .. table.concat(s:alive(), ", "))
      end
    end
  end
  print(sformat("%d steps, %d failed", steps.n, steps.failed))
  return steps.failed == 0 and 0 or 1
end

--- Resets the step counters (for running several scenarios in one process).
function M.reset() steps = { n = 0, failed = 0, lines = {} } systems = {} M.backends = nil end

return M
