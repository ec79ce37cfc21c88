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
-- Faults: sys:kill(path, sig), sys:lose_host(host) (its daemon killed, and what it started), sys:freeze(path) /
-- sys:freeze_host(host) (SIGSTOP: sockets stay open, the heartbeat finds the silence), sys:drop(path, set),
-- sys:crash(path, n, sig, t) (kills `path` n times, default SIGSEGV, each time waiting for its restart by its
-- group's supervision policy; it stops early when the group gives up). Supervision (every wait on a
-- transition line, from line `from`, default: the lines so far): sys:wait_line(what, pattern, t, from),
-- sys:wait_restart(path, t, from), sys:wait_escalation(group, t, from); sys:lines_matching(pattern, from). Conditions: sys:wait(what, pred, t),
-- sys:wait_state(path, state, t), sys:wait_read(path, port, pred, t), sys:wait_outcome(t); sys:host(path);
-- sys:repl(line): a line typed in the root's console (the REPL's commands), its answer.
-- In the real backend (wall clock) a timeout only bounds a hang (it is stretched, see dca.scenario.real.bound) and
-- wait_state is met when the process has been in the state since the last run() (from the transition
-- lines, so a short state is never missed).
--
-- Simulated time with a world (real backend only): S.system(file, { sim = WORLD, seed = N,
-- world_opts = { "KEY=VALUE", ... }, world_host = NAME }) starts the daemons on the simulated clock and the world (`dca sim
-- --serve`, as `dca run --sim` does, through the daemon of world_host, default the first host name) before the
-- tree; run() sends the world `go` once the root's run has been answered. sys:world_status() is the world's
-- `status {}` (t, door_angle, base_pose, latched, ...), sys:world_read(port) its `read {port}` (the latest
-- base.cmd_vel / arm.cmd_qd it received, or a sensor output such as arm.q), sys:world_hold() / world_hold_at(t) / world_go()
-- stop and restart its time, sys:world_hold_when(t) before run() holds it at t however fast it flows (then
-- sys:world_wait_held(t)), sys:wait_world(what, pred(status), t) waits for a condition on its status.
--
-- The trace (ARCHITECTURE.md "Time"): the first system in simulated time writes the run's trace (`dca scenario
-- --trace FILE`, else a temporary file kept only on a failure); a failing scenario prints `seed N, trace FILE,
-- rerun: COMMAND`. `dca scenario --seed N` replaces the seed of the systems in simulated time.
--
-- Configuration: a system's config("key") parameters read the repository; S.system(file, { config = FILE,
-- set = { key = value } }) seeds it as `dca run --config FILE --set KEY=VALUE` does (default: FILE.config
-- beside the .dca file, when there is one). The memory backend reads the same values.
-- A scenario that only makes sense on some backends says so: S.backends = {"real"} (the CMake then makes
-- only those tests; another backend fails with a message saying so).
--
-- Backends: "memory" (dca.scenario.memory) runs the tree in dca.supervisor.memory (simulated time, nodes whose
-- behaviour follows their type: Timer, Deadline, Crash, Constant...; other types run until an event is
-- injected or they are killed); "real" (dca.scenario.real) runs real processes. The backend is chosen with
-- `dca scenario --backend NAME` (default memory).
local spec_mod = require "dca.supervisor.spec"
local T = require "dca.testing"

local M = {}

local ipairs, pairs, type, tostring, sformat, pcall, xpcall = ipairs, pairs, type, tostring, string.format, pcall, xpcall
local traceback = debug.traceback

M.backend = "memory"
M.eq, M.ok, M.contains, M.show = T.eq, T.ok, T.contains, T.show

local steps = { n = 0, failed = 0, lines = {} }
local systems = {}
local traced  -- the system in simulated time whose trace is written: { file, keep, seed }

--- Loads, checks and builds the system in FILE (root `root` or "main"), its device ports held to `world` (nil:
--- the door). Errors stop the scenario.
function M.spec(file, root, world)
  local spec, err = require("dca.load").spec(file, { root = root, world = world })
  if not spec then error(err, 0) end
  return spec
end

-- The methods every backend's system has (after its own).
local Shared = {}

--- A system from a .dca file (or a ready spec with opts.spec), not started yet, on M.backend.
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
  local spec = opts.spec or M.spec(file, opts.root, opts.sim)
  -- the configuration repository: opts.config (a defaults file; default FILE.config beside FILE.dca), then
  -- opts.set = { key = value } over it, as `dca run --config/--set`
  local cfile = opts.config or (file and require("dca.config").defaults_file(file)) or nil
  local backend = require(M.backend == "real" and "dca.scenario.real" or "dca.scenario.memory")
  local bo = { file = file, config = cfile }
  for k, v in pairs(opts) do if bo[k] == nil then bo[k] = v end end
  if opts.sim then M._traced(bo) end
  local s = backend.system(spec, bo)
  for k, f in pairs(Shared) do s[k] = s[k] or f end
  systems[#systems + 1] = s
  return s
end

-- A system in simulated time: `dca scenario --seed` over the scenario's own seed, and the first one traced
-- (`--trace FILE`, else a temporary file kept only if the scenario fails): the world writes FILE.world, the
-- backend merges it with the transition lines into FILE when the system stops (dca.trace).
function M._traced(bo)
  if M.seed then bo.seed = M.seed end
  if bo.trace or traced then return end
  traced = { file = M.trace or os.tmpname(), keep = M.trace ~= nil, seed = bo.seed or 0 }
  if traced.file:sub(1, 1) ~= "/" then traced.file = (os.getenv("PWD") or ".") .. "/" .. traced.file end
  bo.trace, bo.trace_file = traced.file .. ".world", traced.file
end

-- After a failed step: how to see it again (a system in simulated time repeats exactly, ARCHITECTURE.md "Time").
local function rerun_line()
  if not traced then return end
  traced.keep = true
  local a = M.argv or {}
  local cmd = { "dca scenario", "--backend " .. M.backend }
  if a.placement then cmd[#cmd + 1] = "--placement " .. a.placement end
  cmd[#cmd + 1] = "--seed " .. tostring(traced.seed)
  cmd[#cmd + 1] = "--trace " .. traced.file .. ".again"
  cmd[#cmd + 1] = a.file or "FILE.lua"
  print(sformat("  seed %s, trace %s, rerun: %s (then: dca trace diff %s %s.again)", tostring(traced.seed),
    traced.file, table.concat(cmd, " "), traced.file, traced.file))
end

--- The leaves' run and stop commands in the order their supervisors issued them ("main.a run",
--- "main.a stop"), optionally only those matching `pattern`. The same in every backend.
function Shared:commands(pattern)
  local leaf = {}
  spec_mod.walk_all(self.spec, function(n) if n.kind == "leaf" then leaf[n.path] = true end end)
  local out = {}
  for _, l in ipairs(self:transitions()) do
    local path, what = l:match("^(%S+): (%a+)$")
    local cmd = path and leaf[path] and ((what == "running" and path .. " run") or (what == "aborting" and path .. " stop"))
    if cmd and (not pattern or cmd:find(pattern)) then out[#out + 1] = cmd end
  end
  return out
end

--- The host name of the process at `path` (from the system's spec), or nil.
function Shared:host(path)
  local host
  spec_mod.walk_all(self.spec, function(n) if n.path == path then host = n.host end end)
  return host
end

--- A line typed in the root supervisor's console (the REPL's commands, dca.supervisor.console). --> its answer
function Shared:repl(line)
  self.console = self.console or require("dca.supervisor.console").new(self.sup)
  local out
  self.console:eval(line, function(o) out = o end)
  self:wait("the console's answer to " .. line, function() return out ~= nil end, 30)
  return out
end

--- The transition lines after line number `from` (default 0) that match the Lua pattern `pattern`.
function Shared:lines_matching(pattern, from)
  local out, lines = {}, self:transitions()
  for i = (from or 0) + 1, #lines do
    if lines[i]:find(pattern) then out[#out + 1] = lines[i] end
  end
  return out
end

--- Waits for a transition line after line number `from` (default: the lines so far) that matches `pattern`
--- (a Lua pattern, or a list of them: any), at most `timeout` seconds. --> the line, its number
function Shared:wait_line(what, pattern, timeout, from)
  from = from or #self:transitions()
  local patterns = type(pattern) == "table" and pattern or { pattern }
  local found, at
  self:wait(what, function()
    local lines = self:transitions()
    for i = from + 1, #lines do
      for _, p in ipairs(patterns) do
        if lines[i]:find(p) then found, at = lines[i], i return true end
      end
    end
    return false
  end, timeout)
  return found, at
end

local function escape(s) return (s:gsub("%p", "%%%0")) end
local function restarted(path) return "^" .. escape(path) .. ": restarted" end
local function gave_up(path) return "^" .. escape(path) .. ": restart intensity .* exceeded" end

--- Waits until the process at `path` has been restarted (its line "PATH: restarted ..."). --> the line
function Shared:wait_restart(path, timeout, from)
  return self:wait_line(path .. "'s restart", restarted(path), timeout, from)
end

--- Waits until the group `path` gives up: its restart intensity exceeded. --> the line
function Shared:wait_escalation(path, timeout, from)
  return self:wait_line(path .. "'s escalation", gave_up(path), timeout, from)
end

--- Kills the process at `path` with `sig` (default SEGV) `n` times, each time once it lives again: waits until
--- its group has restarted every child it restarts for it, or gives up (then it stops).
--- --> the number of kills, the escalation line or nil
function Shared:crash(path, n, sig, timeout)
  local group = path:match("^(.*)%.[^.]+$") or path
  local restarting = "^" .. escape(group) .. ": %S+ after .*: restarting ([%w_, ]+) %(%d+/"
  for i = 1, n do
    local from = #self:transitions()
    self:kill(path, sig or "SEGV")
    local line, at = self:wait_line(sformat("%s's restart or %s's escalation after kill %d", path, group, i),
      { restarting, gave_up(group) }, timeout, from)
    if line:find(gave_up(group)) then return i, line end
    for name in line:match(restarting):gmatch("[%w_]+") do
      local _, at2 = self:wait_line(sformat("%s's restart after kill %d", group .. "." .. name, i),
        { restarted(group .. "." .. name), gave_up(group) }, timeout, at)
      local l2 = self:transitions()[at2]
      if l2:find(gave_up(group)) then return i, l2 end
    end
  end
  return n, nil
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
  if steps.failed > 0 then rerun_line() end
  if traced and not traced.keep then os.remove(traced.file) end
  print(sformat("%d steps, %d failed", steps.n, steps.failed))
  return steps.failed == 0 and 0 or 1
end

--- Resets the step counters (for running several scenarios in one process).
function M.reset() steps = { n = 0, failed = 0, lines = {} } systems = {} M.backends = nil traced = nil end

return M
