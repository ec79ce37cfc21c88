-- No orphans whatever kills the parent, and signals count from the first instant: `dca run` is started
-- from an argv (core.spawn), its whole process tree is collected from /proc, and then
--   - kill -9 of `dca run` mid-run: within 2 s no process of the run is left (checked by PID) and its temporary
--     directory (the key and the daemons' logs) is gone. On the previous main the three daemons, the world and
--     every node ran on forever (the daemons were started through `sh -c ... &`, in their own session);
--   - SIGINT at 20 moments of the door system's start-up (after its k-th output line, k = 0, 2, ..., 38: hosts,
--     configuration, world, the tree's start of 27 instances, its first steps; the door takes ~20 s of simulated
--     time, so the run is never over before the signal): the run always ends with exit code 130 and nothing of
--     it is left. On the previous main a SIGINT before the loop listened killed `dca run` and left its daemons
--     running, and one between the start's steps was forgotten: the system ran to DONE with code 0.
-- Every wait is for an event (an output line, a process gone) with a deadline; the 2 s is the requirement.
local T = require "dca.testing"
local core = require "dca.core"
local suite = T.suite("orphans")

local dca, src = T.exe, T.src

local function stat(pid)
  local f = io.open("/proc/" .. pid .. "/stat", "r")
  if not f then return nil end
  local st = f:read("l") or ""
  f:close()
  return st
end

-- A process that still runs (a zombie has ended: only its parent's wait is missing).
local function running(pid)
  local st = stat(pid)
  return st ~= nil and not st:match("^%d+ %b() Z")
end

-- Every descendant of `root`, from the parent pids in /proc.
local function descendants(root)
  local children = {}
  for _, name in ipairs(core.list_dir("/proc") or {}) do
    local ppid = name:match("^%d+$") and (stat(name) or ""):match("^%d+ %b() %a (%d+)")
    if ppid then
      children[tonumber(ppid)] = children[tonumber(ppid)] or {}
      table.insert(children[tonumber(ppid)], tonumber(name))
    end
  end
  local out, queue = {}, { root }
  while #queue > 0 do
    local p = table.remove(queue)
    for _, c in ipairs(children[p] or {}) do out[#out + 1] = c queue[#queue + 1] = c end
  end
  return out
end

local function wait_until(pred, seconds)
  local deadline = core.now() + seconds
  while not pred() do
    if core.now() > deadline then return false end
    core.sleep(0.01)
  end
  return true
end

local function lines(path) return select(2, T.read(path):gsub("\n", "")) end

-- Starts `dca run ARGS...` with its output in a fresh file. --> pid, output path
local function start_run(...)
  local out = T.tmpname(".out")
  local pid = assert(core.spawn({ dca, "run", ... }, { stdout = out }))
  return pid, out
end

-- The key directory of a run, from a daemon's argv (--key DIR/key).
local function key_dir(pids)
  for _, p in ipairs(pids) do
    local f = io.open("/proc/" .. p .. "/cmdline", "rb")
    local argv = f and f:read("a") or ""
    if f then f:close() end
    local key = argv:match("%-%-key%z([^%z]+)")
    if key and argv:find("daemon", 1, true) then return (key:gsub("/key$", "")) end
  end
end

local function left_over(pids)
  local alive = {}
  for _, p in ipairs(pids) do if running(p) then alive[#alive + 1] = p end end
  return alive
end

-- "PID argv" of each process, for a failure message.
local function named(pids)
  local out = {}
  for _, p in ipairs(pids) do
    local f = io.open("/proc/" .. p .. "/cmdline", "rb")
    out[#out + 1] = p .. " " .. (f and f:read("a"):gsub("%z", " "):sub(1, 80) or "?")
    if f then f:close() end
  end
  return table.concat(out, "; ")
end

local function kill_all(pids) for _, p in ipairs(pids) do core.kill(p, "KILL") end end

suite:case("kill_9_of_dca_run_mid_run_leaves_no_process_and_no_temp_dir_after_2_s", function()
  local pid, out = start_run(src .. "/worlds/door/systems/door_open.dca", "--sim", "door")
  local up = wait_until(function() return T.read(out):find("approach: running", 1, true) ~= nil end, 60)
  local pids = descendants(pid)
  local dir = key_dir(pids)
  T.ok(up, "the door run reached its approach step:\n" .. T.read(out))
  T.ok(#pids >= 10 and dir ~= nil, "daemons, world, supervisors and nodes found: " .. #pids)
  core.kill(pid, "KILL")
  local t0 = core.now()
  local gone = wait_until(function() return #left_over(pids) == 0 end, 2)
  local alive = left_over(pids)
  kill_all(alive)
  T.ok(gone, string.format("%d of %d processes still run %.1f s after kill -9: %s", #alive, #pids, core.now() - t0,
    table.concat(alive, " ")))
  T.ok(wait_until(function() return io.open(dir .. "/key") == nil end, 2), "the temporary directory is removed: " .. dir)
  core.reap(pid)
  os.remove(out)
end)

-- kill -9 of the world (the robot process, the clock master) mid-run: the run ends ABORTED with the cause and
-- exit code 1, and nothing of it is left. On the previous main it printed the world's end, then waited for ever
-- with its daemons and supervisors up and no outcome.
suite:case("kill_9_of_the_world_ends_the_run_aborted_and_leaves_nothing", function()
  local pid, out = start_run(src .. "/worlds/door/systems/door_open.dca", "--sim", "door")
  local up = wait_until(function() return T.read(out):find("approach: running", 1, true) ~= nil end, 60)
  local pids = descendants(pid)
  T.ok(up, "the door run reached its approach step:\n" .. T.read(out))
  local world
  for _, p in ipairs(pids) do
    local f = io.open("/proc/" .. p .. "/cmdline", "rb")
    local argv = f and f:read("a") or ""
    if f then f:close() end
    if argv:find("%zsim%z") and argv:find("%-%-serve") then world = p end
  end
  T.ok(world, "the world found among " .. named(pids))
  core.kill(world, "KILL")
  local ended = wait_until(function() return core.reap(pid) ~= nil or not running(pid) end, 60)
  local alive = left_over(pids)
  kill_all(alive)
  if not ended then core.kill(pid, "KILL") end
  local text = T.read(out)
  T.ok(ended, "dca run ended after its world was killed:\n" .. text)
  T.contains(text, "killed by SIGKILL")
  T.contains(text, "main: ABORTED")
  T.contains(text, "the robot process was lost: the world killed by SIGKILL")
  T.ok(wait_until(function() return #left_over(pids) == 0 end, 5), "left: " .. named(left_over(pids)))
  os.remove(out)
end)

-- With daemons started by hand (a hosts file), `dca run` dying leaves them running, but nothing of its run: the
-- world (whose clock master was the root), the supervisors and the nodes of the run are gone within 2 s.
suite:case("kill_9_of_dca_run_on_hand_started_daemons_leaves_only_the_daemons", function()
  local hosts = require "dca.launch.hosts"
  local key, dir = hosts.fresh_key()
  local names = { "manipulation", "platform", "vision" }
  local set = assert(hosts.start_local(names, { exe = dca, key = key, clock = "sim", log_dir = dir }))
  local lines = {}
  for _, h in ipairs(names) do lines[#lines + 1] = h .. " " .. set.hosts[h] end
  local hosts_file = T.write(dir .. "/hosts", table.concat(lines, "\n") .. "\n")
  local out = T.tmpname(".out")
  local pid = assert(core.spawn({ "/usr/bin/env", "DCA_KEY_FILE=" .. key, dca, "run",
    src .. "/worlds/door/systems/door_open.dca", "--sim", "door", "--placement", "process", "--hosts", hosts_file },
    { stdout = out }))
  local up = wait_until(function() return T.read(out):find("approach: running", 1, true) ~= nil end, 60)
  local of_run = {}
  for _, h in ipairs(names) do
    for _, p in ipairs(descendants(set.pids[h])) do of_run[#of_run + 1] = p end
  end
  T.ok(up and #of_run >= 10, "the run came up on the daemons (" .. #of_run .. " processes):\n" .. T.read(out))
  core.kill(pid, "KILL")
  local gone = wait_until(function() return #left_over(of_run) == 0 end, 2)
  local alive = left_over(of_run)
  local alive_named = named(alive)
  kill_all(alive)
  local daemons_up = true
  for _, h in ipairs(names) do daemons_up = daemons_up and running(set.pids[h]) end
  set:stop()
  core.remove_tree(dir)
  core.reap(pid)
  os.remove(out)
  T.ok(gone, "still running 2 s after kill -9 of dca run: " .. alive_named)
  T.ok(daemons_up, "the hand-started daemons keep running")
end)

suite:case("sigint_at_20_moments_of_start_up_ends_with_130_and_leaves_nothing", function()
  local system = src .. "/worlds/door/systems/door_open.dca"
  for k = 0, 38, T.sanitized and 13 or 2 do  -- (every 13th line under the sanitizers: 3 moments)
    local pid, out = start_run(system, "--sim", "door")
    T.ok(wait_until(function() return lines(out) >= k end, 30), "line " .. k .. " came:\n" .. T.read(out))
    local pids = descendants(pid)
    core.kill(pid, "INT")
    local ended
    T.ok(wait_until(function() ended = ended or core.reap(pid) return ended ~= nil end, 30), "the run ended")
    -- before main (k = 0 only) the default action ends it by SIGINT, which a shell reports as 130 too
    local early = k == 0 and ended.signal == 2 and #pids == 0
    T.ok(ended.code == 130 or early, string.format("SIGINT after line %d: %s\n%s", k, T.show(ended), T.read(out)))
    local gone = wait_until(function() return #left_over(pids) == 0 and #left_over(descendants(pid)) == 0 end, 2)
    local alive = left_over(pids)
    kill_all(alive)
    T.ok(gone, "after line " .. k .. ", still running: " .. table.concat(alive, " "))
    os.remove(out)
  end
end)

suite:case("spawn_passes_every_argument_intact_and_refuses_a_nul", function()
  local out = T.tmpname(".out")
  local hostile = "h'; touch /tmp/dca_pwned_$$ #\n\"x\" $(id)"
  local pid = assert(core.spawn({ "/bin/echo", hostile }, { stdout = out }))
  T.ok(wait_until(function() return core.reap(pid) ~= nil end, 10), "echo ended")
  T.eq(T.read(out), hostile .. "\n", "the argument reached the program as it is")
  local none, err = core.spawn({ "/bin/echo", "a\0b" })
  T.eq(none, nil, "a NUL is refused")
  T.contains(err, "NUL")
  os.remove(out)
end)

-- No part of the launch path starts a process or removes a file through a shell: a host name holding quotes,
-- newlines or NULs cannot reach one.
suite:case("the_launch_path_never_goes_through_a_shell", function()
  for _, file in ipairs({ "launch/hosts.lua", "launch/start.lua", "launch/run.lua", "launch/sim.lua",
                          "launch/group.lua", "scenario/real.lua", "cli/run.lua" }) do
    local text = T.read(src .. "/lua/dca/" .. file)
    for _, call in ipairs({ "io.popen", "os.execute" }) do
      T.ok(not text:find(call, 1, true), file .. " calls " .. call)
    end
  end
end)
return suite:run(...)
