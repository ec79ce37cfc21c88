-- Restart of a leaf while the system runs (the REPL's restart(path), Sup:restart_leaf): a fresh process of the
-- same instance with its config("key") arguments read again; its PID changes and no other process's does;
-- samples flow again both ways (from a writer in another group, to its reader); the task carries on to DONE.
-- Without restart (or on a tree where a writer kept its link to the old process) the waits below time out.
local S = require "dca.scenario"
local src = os.getenv("DCA_SOURCE_DIR") or "."
local sys = S.system(src .. "/scripts/systems/test_restart.dca")

local PROCESSES = { "main.src", "main.pipe", "main.pipe.gain", "main.pipe.sink", "main.pipe.count" }
-- Under a shared placement (`dca scenario --placement group|host`) a restarted leaf is a fresh instance in the
-- same shared node (host/node.h `remove` then `add`): its pid stays, its config("key") arguments are read again,
-- and the answer says it runs the code that process loaded (dca.supervisor.restart code_check).
local shared = sys.backend == "real" and (S.placement or "process") ~= "process"

-- The pid of the live process at `path` (memory: the in-memory cluster's process slots).
local function pid(path)
  if sys.backend ~= "memory" then return sys:pid(path) end
  for _, p in ipairs(sys.c.procs) do if p.path == path and p.alive then return p.pid end end
end

local function pids()
  local t = {}
  for _, p in ipairs(PROCESSES) do t[p] = pid(p) end
  return t
end

-- A line typed in the root supervisor's console, as `dca repl` sends it. --> its output
local repl
local function type_line(line)
  repl = repl or require("dca.supervisor.console").new(sys.backend == "memory" and sys.c.root_sup or sys.sup)
  local out
  repl:eval(line, function(o) out = o end)
  sys:wait("the console's answer to " .. line, function() return out ~= nil end, 30)
  return out
end

-- The pids of every process but `except` are those of `before`, and they all live.
local function others_unchanged(before, except)
  local now = pids()
  for _, p in ipairs(PROCESSES) do
    S.ok(now[p] ~= nil, p .. " lives")
    if p ~= except then S.eq(now[p], before[p], p .. " never stopped") end
  end
end

S.step("the system runs: the Gain (k = 0 from the repository) feeds its reader zeros", function()
  sys:up()
  sys:run()
  sys:wait_read("main.pipe.gain", "In", function(v) return v == 1 end, 10)
  sys:wait_read("main.pipe.sink", "Out", function(v) return v == 0 end, 10)
end)

-- Sets `key` to `value` in the repository of h2, restarts `path` from the console: a new process, the others
-- untouched. --> the pids before
local function restart(path, key, value)
  local before = pids()
  sys:config("h2"):set(key, value)
  local said = type_line("restart('" .. path:gsub("^main%.", "") .. "')")
  if shared then
    S.contains(said, path .. ": restarted (a fresh instance in shared node leaves:")
    S.contains(said, "#" .. before[path] .. " (--placement " .. S.placement .. "), with the code that process loaded)")
    S.eq(pid(path), before[path], "a fresh instance in the same shared node")
  else
    S.eq(said, path .. ": restarted")
    S.ok(pid(path) ~= before[path], "a new process")
  end
  others_unchanged(before, path)
  return before
end

S.step("restart('pipe.gain') with k = 2 in the repository: a new process, the others untouched", function()
  restart("main.pipe.gain", "test.gain", 2)
  S.eq(sys:state("main.pipe.gain"), "running")
end)

S.step("samples flow again: from main.src (another group) into it, and its new output to its reader", function()
  -- the reader sees 2 only when the new process has samples from main.src and its output reaches main.pipe.sink
  sys:wait_read("main.pipe.sink", "Out", function(v) return v == 2 end, 10)
  sys:wait_read("main.pipe.gain", "In", function(v) return v == 1 end, 10)
end)

S.step("restart('pipe.count') with a limit of 3: the task carries on to DONE", function()
  local before = restart("main.pipe.count", "test.limit", 3)
  local out = sys:wait_outcome(30)
  S.eq(out.type, "done")
  S.eq(out.value, 3)
  others_unchanged(before, "main.pipe.count")
  S.eq(#sys:commands("main.pipe.gain stop"), 1, "the restarted Gain stopped once, by the end of its group")
end)

S.step("errors: an unknown path, and a leaf whose process is gone", function()
  S.contains(type_line("restart('main.nobody')"), "no process 'main.nobody' under main")
  sys:kill("main.src", "KILL")
  sys:wait("main.src's exit", function() return sys:state("main.src") == "exited" end, 10)
  S.contains(type_line("restart('main.src')"), "main.src is not running (")
end)
return S.finish()
