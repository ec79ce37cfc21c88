-- A rolling upgrade of a controller package (docs/deploy.md, "Rolling upgrade of a package"): three hosts, each a
-- daemon on loopback with its own state directory (its package store), each running a group Robot of
-- Counter -> PkgScale (pkg_ok, k = 2 as built, from the `packages/` folder beside the system) -> Threshold under
-- a one_for_one policy; main restarts a group that escalates. upgrade() in the root's console rolls a rebuilt
-- pkg_ok (tests/packages/CMakeLists.txt, lib/variants/) to the canary h2, then h1 and h3:
--   - k = 3: every host installs it, each PkgScale is restarted onto it and its sink then reads multiples of 3 (the
--     leaf's output says which version it runs), no other process stopped, every daemon reports the new version,
--     and the repository holds the upgrade's record beside the keys it had;
--   - a build that aborts at its first sample: the canary's leaf crashes in the watch window, h2 is rolled back
--     (its leaf runs k = 2 again), the roll stops, h1 and h3 never receive the new version (their daemons hold
--     none, their leaves never restarted), and the repository records the rollback and why;
--   - a build whose output no longer has the name the system connects: its restart on the canary is refused
--     (never wired), h2 is rolled back, h1 and h3 never receive it, and main starts the robot that the failed
--     restart ended again, on the old file.
-- Every wait is on an event (a console answer, a sample read, a transition line) with a deadline that only
-- bounds a hang; the crash's watch window is long (60 s) and ended by the crash itself.
local T = require "dca.testing"
local suite = T.suite("upgrade")

local dca = T.exe
local packages = os.getenv("DCA_TEST_PACKAGES_DIR") or error("DCA_TEST_PACKAGES_DIR is not set")

local SYSTEM = T.read(T.src .. "/tests/lua/launch/upgrade_robots.dca")

-- The scenario's common part: the system up and running on k = 2 everywhere, a key in the repository;
-- factor(host, k, above) waits for a sample at that host's sink that only k writes; daemon(host, msg) asks
-- a host's daemon; pids() the processes of every robot.
local PRELUDE = [[
local S = require "dca.scenario"
S.backends = { "real" }
local DIR, VARIANTS = %q, %q
local sys = S.system(DIR .. "/upgrade.dca")
local HOSTS = { "h1", "h2", "h3" }
local function factor(host, k, above)
  local other = k == 2 and 3 or 2
  local v
  sys:wait_read("main.r" .. host:sub(2) .. ".sink", "In", function(x)
    if type(x) == "number" and x > (above or 0) and x %% k == 0 and x %% other ~= 0 then v = x return true end
  end, 20)
  return v
end
local function daemon(host, msg)
  local r, err = sys:_ask(function(k) sys:_daemon(host):request(msg, 20, k) end, 25, "daemon " .. host)
  S.ok(r and r.type ~= "error", "daemon " .. host .. ": " .. tostring(err or (r and r.reason)))
  return r
end
local function pids()
  local t = {}
  for i = 1, 3 do
    for _, leaf in ipairs({ "src", "sc", "sink" }) do local p = "main.r" .. i .. "." .. leaf t[p] = sys:pid(p) end
  end
  return t
end
local function version_of(file)
  local f = assert(io.open(file, "rb"))
  local v = require("dca.core").package_version(f:read("a"))
  f:close()
  return v
end
local OLD = version_of(DIR .. "/packages/pkg_ok.dca.so")
-- the repository of `host` once it holds the upgrade's record in `state` (replicated from the root's host),
-- after checking the key written before the upgrade is still there. --> the record, the repository
local function record(host, state)
  local c = sys:config(host)
  S.eq(c:get("robot.kept"), 7, "a key written before the upgrade")
  sys:wait("the record at " .. host, function()
    local ok, rec = pcall(c.get, c, "upgrade.pkg_ok")
    return ok and rec.state == state
  end, 20)
  return c:get("upgrade.pkg_ok"), c
end
local before, last
S.step("the system runs pkg_ok as built (k = 2) on h1, h2 and h3", function()
  sys:up()
  sys:run()
  sys:config("h1"):set("robot.kept", 7)
  last = {}
  for _, h in ipairs(HOSTS) do last[h] = factor(h, 2) end
  before = pids()
  for _, h in ipairs(HOSTS) do
    local r = daemon(h, { type = "package_status", name = "pkg_ok", system_dir = DIR })
    S.eq(#r.packages, 0, h .. " holds no installed version")
    S.eq(r.loads.version, OLD, h .. " loads the packages/ folder's")
  end
end)
]]

-- Runs the scenario `steps` (after the prelude) with `dca scenario --backend real` (and --placement
-- `placement`). --> output, rc
local function scenario(steps, placement)
  local dir = T.tmpdir()
  os.execute("mkdir '" .. dir .. "/packages' && cp '" .. packages .. "/pkg_ok.dca.so' '" .. dir .. "/packages/'")
  T.write(dir .. "/upgrade.dca", SYSTEM)
  local file = T.write(dir .. "/upgrade.lua", string.format(PRELUDE, dir, packages .. "/variants") .. steps
    .. "\nreturn S.finish()\n")
  local out, rc = T.sh("timeout 220 " .. dca .. " scenario --backend real "
    .. (placement and "--placement " .. placement .. " " or "") .. file)
  T.kept_logs(out)
  return out, rc
end

suite:case("a_new_version_rolled_from_the_canary_to_every_host_runs_everywhere_and_is_recorded", function()
  local out, rc = scenario([[
S.step("upgrade(k = 3) with canary h2: every host installs it, each PkgScale restarted onto it", function()
  local NEW = version_of(VARIANTS .. "/k3/pkg_ok.dca.so")
  local said = sys:repl(string.format("upgrade(%q, { canary = 'h2', watch = 0.5 })", VARIANTS .. "/k3/pkg_ok.dca.so"))
  S.contains(said, "upgrade pkg_ok: plan: ")
  S.contains(said, "(version " .. NEW:sub(1, 12) .. ") to 3 hosts, leaf by leaf: h2 [canary] (main.r2.sc, runs "
    .. OLD:sub(1, 12) .. "), then h1 (main.r1.sc, runs " .. OLD:sub(1, 12) .. "), then h3 (main.r3.sc, runs "
    .. OLD:sub(1, 12) .. "); the canary watched 0.5 s")
  S.contains(said, "upgrade pkg_ok: h2: installed version " .. NEW:sub(1, 12) .. " (was " .. OLD:sub(1, 12) .. ")")
  S.contains(said, "upgrade pkg_ok: h2: the canary ran 0.5 s with no crash or escalation")
  S.contains(said, "upgrade pkg_ok: done: 3 hosts run version " .. NEW:sub(1, 12) .. " (h2, h1, h3)")
  -- the order: the canary's restart and watch before any other host's install
  local order = {}
  for l in said:gmatch("[^\n]+") do
    local h, what = l:match("^upgrade pkg_ok: (h%d): (%a+)")
    if h then order[#order + 1] = h .. " " .. what end
  end
  S.eq(order, { "h2 installed", "h2 main", "h2 watching", "h2 the", "h1 installed", "h1 main", "h3 installed",
                "h3 main" })
  for _, h in ipairs(HOSTS) do
    factor(h, 3, last[h])
    local r = daemon(h, { type = "package_status", name = "pkg_ok", system_dir = DIR })
    S.eq(r.packages[1].version, NEW, h .. " runs the new version")
    S.eq(r.packages[1].previous, "", h .. ": none was installed before")
    S.eq(r.loads.version, NEW, h .. " loads the installed one")
  end
  local now = pids()
  for p, pid in pairs(before) do
    if p:match("%.sc$") then S.ok(now[p] ~= pid, p .. " is a new process")
    else S.eq(now[p], pid, p .. " never stopped") end
  end
  S.eq(sys:state("main"), "running")
end)
S.step("the repository keeps its keys and records the upgrade", function()
  local NEW = version_of(VARIANTS .. "/k3/pkg_ok.dca.so")
  local rec, c = record("h3", "done")
  S.eq(rec.version, NEW)
  S.eq(rec.canary, "h2")
  S.eq(rec.order, { "h2", "h1", "h3" })
  S.eq(rec.from, { h1 = OLD, h2 = OLD, h3 = OLD })
  for _, h in ipairs(HOSTS) do S.eq(c:get("packages.pkg_ok." .. h), NEW) end
  -- its first record (rolling) is in the log too
  local states = {}
  for _, t in ipairs(c:log(20).txns) do
    for _, w in ipairs(t.writes) do if w.key == "upgrade.pkg_ok" then states[#states + 1] = w.value.state end end
  end
  S.eq(states[#states], "rolling", "the oldest record")
  S.eq(states[1], "done", "the newest record")
end)
]])
  T.eq(rc, 0, "the scenario passes\n" .. out)
end)

suite:case("a_canary_that_crashes_is_rolled_back_and_no_other_host_receives_the_new_version", function()
  local out, rc = scenario([[
S.step("upgrade(a build that aborts) with canary h2: its leaf crashes, h2 rolled back, the roll stopped", function()
  local NEW = version_of(VARIANTS .. "/crash/pkg_ok.dca.so")
  local said = sys:repl(string.format("upgrade(%q, { canary = 'h2', watch = 60 })", VARIANTS .. "/crash/pkg_ok.dca.so"))
  S.contains(said, "upgrade pkg_ok: h2: installed version " .. NEW:sub(1, 12))
  S.contains(said, "upgrade pkg_ok: h2: failed: ")
  S.contains(said, "upgrade pkg_ok: h2: rolled back to " .. OLD:sub(1, 12))
  S.contains(said, "upgrade pkg_ok: rolled back on h2 and stopped (h1, h3 never received version "
    .. NEW:sub(1, 12) .. "): ")
  S.ok(not said:find("h1: installed") and not said:find("h3: installed"), "nothing sent to h1 and h3:\n" .. said)
  S.contains(said:match("upgrade pkg_ok: h2: failed: [^\n]*"), "main.r2.sc", "the canary's leaf is why")
  -- (it died at its first sample: once running, or, rarely, before its restart was through)
  S.ok(#sys:lines_matching("^main%.r2%.sc: .*SIGABRT") > 0, "the canary's leaf crashed")
end)
S.step("h2 runs k = 2 again; h1 and h3 never saw the new version", function()
  local NEW = version_of(VARIANTS .. "/crash/pkg_ok.dca.so")
  factor("h2", 2, last.h2)
  local r = daemon("h2", { type = "package_status", name = "pkg_ok", system_dir = DIR })
  S.eq(r.packages[1].version, "", "h2: nothing installed now")
  S.eq(r.packages[1].previous, NEW, "h2 keeps the bad one as previous")
  S.eq(r.loads.version, OLD, "h2 loads the packages/ folder's again")
  local now = pids()
  for _, h in ipairs({ "h1", "h3" }) do
    r = daemon(h, { type = "package_status", name = "pkg_ok", system_dir = DIR })
    S.eq(#r.packages, 0, h .. " never received a version")
    for _, leaf in ipairs({ "src", "sc", "sink" }) do
      local p = "main.r" .. h:sub(2) .. "." .. leaf
      S.eq(now[p], before[p], p .. " never stopped")
    end
    factor(h, 2, last[h])
  end
  S.eq(sys:state("main"), "running")
end)
S.step("the repository records the rollback and why, and keeps its keys", function()
  local rec, c = record("h1", "rolled back")
  S.eq(rec.canary, "h2")
  S.contains(rec.reason, "main.r2.sc")
  S.eq(next(rec.hosts), nil, "no host runs it")
  local ok = pcall(c.get, c, "packages.pkg_ok.h1")
  S.eq(ok, false, "no host recorded as running it")
end)
]])
  T.eq(rc, 0, "the scenario passes\n" .. out)
end)

suite:case("a_new_version_whose_ports_misfit_fails_its_restart_on_the_canary_and_is_rolled_back", function()
  local out, rc = scenario([[
S.step("upgrade(a build whose output Out is named Scaled) with canary h2: refused there, rolled back", function()
  local said = sys:repl(string.format("upgrade(%q, { canary = 'h2', watch = 60 })", VARIANTS .. "/renamed/pkg_ok.dca.so"))
  -- (why, as the restart's refusal or as its group's ABORTED that follows it: whichever reaches the root first)
  S.contains(said:match("upgrade pkg_ok: h2: failed: [^\n]*"), "restart of main.r2.sc refused: its new code has no "
    .. "output 'Out' (outputs are: Scaled), which connection main.r2.sc.Out -> main.r2.sink.In (set main.r2:sc[run]) uses")
  S.contains(said, "upgrade pkg_ok: h2: rolled back to " .. OLD:sub(1, 12))
  S.contains(said, "upgrade pkg_ok: rolled back on h2 and stopped (h1, h3 never received version ")
  local r = daemon("h2", { type = "package_status", name = "pkg_ok", system_dir = DIR })
  S.eq(r.loads.version, OLD, "h2 loads the packages/ folder's again")
  for _, h in ipairs({ "h1", "h3" }) do
    S.eq(#daemon(h, { type = "package_status", name = "pkg_ok", system_dir = DIR }).packages, 0, h)
  end
  S.eq(record("h2", "rolled back").canary, "h2")
  -- what follows is the system's: a live restart refused for its ports ends the leaf ABORTED for its group's
  -- algebra (docs/packages.md, "Rebuild and restart"), which ends the robot; main starts it again, on the old file
  sys:wait_restart("main.r2", 30, 0)
  factor("h2", 2)
end)
]])
  T.eq(rc, 0, "the scenario passes\n" .. out)
end)

suite:case("in_shared_nodes_the_upgraded_leaves_move_to_processes_of_their_own_where_a_crash_ends_only_them", function()
  -- --placement host: each host's src, sc and sink share one node, which cannot replace a package it loaded
  local out, rc = scenario([[
S.step("the three leaves of each host share one process", function()
  for _, h in ipairs(HOSTS) do
    local i = h:sub(2)
    S.eq(before["main.r" .. i .. ".sc"], before["main.r" .. i .. ".src"], h .. ": sc in the shared node")
    S.eq(before["main.r" .. i .. ".sink"], before["main.r" .. i .. ".src"], h .. ": sink in the shared node")
  end
end)
local K3 = version_of(VARIANTS .. "/k3/pkg_ok.dca.so")
S.step("upgrade(k = 3) with canary h2: each PkgScale leaves its shared node and runs the new version", function()
  local said = sys:repl(string.format("upgrade(%q, { canary = 'h2', watch = 0.5 })", VARIANTS .. "/k3/pkg_ok.dca.so"))
  S.contains(said, "upgrade pkg_ok: done: 3 hosts run version " .. K3:sub(1, 12) .. " (h2, h1, h3)")
  local moved = said:match("upgrade pkg_ok: h1: main.r1.sc restarted %(1/1%): ([^\n]*)") or ""
  S.contains(moved, "moved out of shared node leaves:main@h1#")
  S.contains(moved, " (--placement host) (2 other leaves) to a process of its own: it loads package 'pkg_ok' as "
    .. "its host has it now")
  local now = pids()
  for _, h in ipairs(HOSTS) do
    local i = h:sub(2)
    last[h] = factor(h, 3, last[h])
    S.eq(daemon(h, { type = "package_status", name = "pkg_ok", system_dir = DIR }).loads.version, K3, h)
    S.ok(now["main.r" .. i .. ".sc"] ~= now["main.r" .. i .. ".src"], h .. ": sc in a process of its own")
    for _, leaf in ipairs({ "src", "sink" }) do
      local p = "main.r" .. i .. "." .. leaf
      S.eq(now[p], before[p], p .. " never stopped")
    end
  end
  before = now
  S.eq(sys:state("main"), "running")
end)
S.step("upgrade(a build that aborts) with canary h2: its leaf crashes alone, h2 rolled back to k = 3", function()
  local NEW = version_of(VARIANTS .. "/crash/pkg_ok.dca.so")
  local said = sys:repl(string.format("upgrade(%q, { canary = 'h2', watch = 60 })", VARIANTS .. "/crash/pkg_ok.dca.so"))
  S.contains(said, "upgrade pkg_ok: h2: installed version " .. NEW:sub(1, 12))
  S.contains(said, "upgrade pkg_ok: h2: rolled back to " .. K3:sub(1, 12))
  S.contains(said, "upgrade pkg_ok: rolled back on h2 and stopped (h1, h3 never received version ")
  S.ok(#sys:lines_matching("^main%.r2%.sc: .*SIGABRT") > 0, "the canary's leaf crashed")
  factor("h2", 3, last.h2)
  local now = pids()
  for _, p in ipairs({ "main.r2.src", "main.r2.sink", "main.r1.sc", "main.r3.sc" }) do
    S.eq(now[p], before[p], p .. " never stopped: the crash ended only the upgraded leaf's process")
  end
  S.eq(sys:state("main"), "running")
end)
]], "host")
  T.eq(rc, 0, "the scenario passes\n" .. out)
end)

return suite:run(...)
