-- dca.supervisor.upgrade: a rolling upgrade of a controller package (docs/deploy.md, "Rolling upgrade of a
-- package"), run by a supervisor (the root, normally) over the leaves of its tree that use the package.
--
--   upgrade.run(sup, { name =, data = | file =, canary = HOST, watch = SECONDS }, cb)  -- cb(true, summary) |
--                                                                                     -- cb(nil, summary)
--   upgrade.plan(sup, name) --> { hosts = { HOST, ... }, leaves = { HOST = { path, ... } }, system_dir } | nil, err
--
-- The new file goes to one host first, the canary: its daemon installs it (package_install: the daemon's
-- package store, host/package_store.h, keeps the version it replaced), then each leaf of the package on that host
-- is restarted live (dca.supervisor.restart: a fresh node loads the file as it is now; a leaf in a shared node
-- moves to a node of its own, as the shared one cannot replace what it loaded), one after the other. The
-- canary is then watched for `watch` seconds: a leaf of their groups that exits, aborts or is lost, or a group
-- above them that aborts, escalates or is lost, fails it (M.failure). Then every other host the same way, in
-- name order, without the watch (a standby host of those leaves gets the file, with nothing to restart). A host
-- that fails is rolled back (package_rollback, then its restarted leaves restarted again onto the old file) and
-- the roll stops there: the hosts after it never receive the new version.
-- Each step is a line of the supervisor's (`upgrade NAME: ...`: the `dca run` output, the consoles following it),
-- and the upgrade is recorded in the configuration repository: upgrade.NAME (its state, versions, canary, the
-- reason of a rollback) and packages.NAME.HOST (the version each host runs), written as each step is done.
local async, core = require "dca.async", require "dca.core"
local spec_mod = require "dca.supervisor.spec"

local M = {}

local ipairs, pairs, type, tostring, tonumber = ipairs, pairs, type, tostring, tonumber
local sformat, concat, sort = string.format, table.concat, table.sort

M.WATCH = 5           -- seconds the canary is watched by default
M.TIMEOUT = 30        -- seconds a daemon's package request may take (the file crosses the network)

local function short(v) return (v == nil or v == "") and "none" or tostring(v):sub(1, 12) end
M.short = short

--- The hosts running leaves of package `name` below `sup`, and those leaves; a standby host of one of them (it
--- fails over there) is in the plan too, with no leaf: it gets the file, so that a leaf failing over runs the
--- version its host had. --> { hosts, leaves = { HOST = { path... } }, standby = { HOST = true }, system_dir }
--- | nil, err
function M.plan(sup, name)
  local leaves, hosts, standby, system_dir = {}, {}, {}, nil
  local function add(h)
    if not leaves[h] then leaves[h] = {} hosts[#hosts + 1] = h end
    return leaves[h]
  end
  spec_mod.walk(sup.spec, function(n)
    if n.kind == "leaf" and n.package == name then
      local l = add(n.host)
      l[#l + 1] = n.path
      for _, h in ipairs(n.standby or {}) do standby[h] = true end
      system_dir = system_dir or n.system_dir
    end
  end)
  for h in pairs(standby) do add(h) end
  for h in pairs(standby) do if #leaves[h] > 0 then standby[h] = nil end end
  if #hosts == 0 then
    local used, seen = {}, {}
    spec_mod.walk(sup.spec, function(n)
      if n.kind == "leaf" and n.package and not seen[n.package] then
        seen[n.package] = true
        used[#used + 1] = n.package
      end
    end)
    sort(used)
    return nil, sformat("no leaf of %s uses package '%s' (%s)", sup.path, tostring(name),
      #used > 0 and "packages used: " .. concat(used, ", ") or "it uses no package")
  end
  sort(hosts)
  for _, l in pairs(leaves) do sort(l) end
  return { hosts = hosts, leaves = leaves, standby = standby, system_dir = system_dir }
end

-- The package's name and bytes from the request: data (with name) or file (NAME.dca.so). --> name, data | nil, err
local function payload(req)
  local name = req.name
  if req.file then
    name = name or tostring(req.file):match("([%w_]+)%.dca%.so$")
    if not name then return nil, sformat("%s: a package file is named NAME.dca.so", tostring(req.file)) end
    local f, err = io.open(req.file, "rb")
    if not f then return nil, tostring(err) end
    local data = f:read("a")
    f:close()
    return name, data
  end
  if type(name) ~= "string" or type(req.data) ~= "string" then
    return nil, "upgrade: give the package file (file), or its name and bytes (name, data)"
  end
  return name, req.data
end

-- A daemon request of `host` through the supervisor's runtime. cb(reply) | cb(nil, err)
local function ask(sup, host, msg, cb)
  sup.rt.daemon(host, function(dc, err)
    if not dc then cb(nil, err) return end
    dc:request(msg, M.TIMEOUT, function(r, rerr) cb(async.outcome(r, rerr)) end)
  end)
end

-- Runs fn(item, next) over `list` in order; done() after the last (fn calls next() to go on, or stops).
local function each(list, fn, done)
  local i = 0
  local function step()
    i = i + 1
    if i > #list then done() return end
    fn(list[i], step)
  end
  step()
end

-- A transition line that fails the host being rolled: a leaf of a group of its upgraded leaves (one of them, or
-- a sibling: the new code may break what it feeds) exited, aborted or was lost, or a group above one of them
-- aborted, escalated or was lost. --> the reason | nil
local BAD = { exited = true, aborted = true, lost = true, escalated = true }
local function failure(u, line)
  local path, word = tostring(line):match("^(%S+): (%a+)")
  if not (path and BAD[word]) then return nil end
  if u.watched_groups[path] or u.watched_parents[path:match("^(.*)%.[^.]+$") or ""] then return line end
end

--- What fails a host whose leaves `leaves` were restarted (M.failure): u.watched_parents, the groups that hold
--- them, and u.watched_groups, every group above them up to the supervisor's own.
function M.watch(u, sup, leaves)
  u.watched_parents, u.watched_groups = {}, {}
  for _, path in ipairs(leaves) do
    local p = path:match("^(.*)%.[^.]+$")
    u.watched_parents[p] = true
    while p and #p >= #sup.path do
      u.watched_groups[p] = true
      p = p:match("^(.*)%.[^.]+$")
    end
  end
end

--- The rolling upgrade (see the header). Only one at a time per supervisor.
function M.run(sup, req, cb)
  if not sup.rt.daemon then cb(nil, "upgrade: the supervisor's runtime reaches no daemons (a real run only)") return end
  if sup.upgrading then
    cb(nil, sformat("upgrade: %s is already upgrading package '%s'", sup.path, sup.upgrading))
    return
  end
  local name, data = payload(req)
  if not name then cb(nil, data) return end
  local plan, perr = M.plan(sup, name)
  if not plan then cb(nil, "upgrade: " .. perr) return end
  local running = {}
  for _, h in ipairs(plan.hosts) do if not plan.standby[h] then running[#running + 1] = h end end
  local canary = req.canary or running[1]
  if not plan.leaves[canary] or plan.standby[canary] then
    cb(nil, sformat("upgrade %s: the canary %s runs no leaf of it (hosts that do: %s)", name, tostring(canary),
      concat(running, ", ")))
    return
  end
  local watch = tonumber(req.watch) or M.WATCH
  if watch < 0 or watch > 3600 then cb(nil, "upgrade: watch is seconds from 0 to 3600") return end
  local order = { canary }
  for _, h in ipairs(plan.hosts) do if h ~= canary then order[#order + 1] = h end end
  local u = { sup = sup, name = name, data = data, plan = plan, order = order, canary = canary, watch = watch,
              version = nil, from = {}, done = {}, lines = {} }
  sup.upgrading = name
  local function say(fmt, ...)
    local line = sformat("upgrade %s: " .. fmt, name, ...)
    u.lines[#u.lines + 1] = line
    sup:say("%s", line)
  end
  u.say = say
  local function finish(ok, summary)
    sup.upgrading = nil
    sup.upgrade_tap = nil
    if u.timer then u.timer:cancel() u.timer = nil end
    say("%s", summary)
    cb(ok, concat(u.lines, "\n"))
  end
  -- what each host loads now (and every daemon reached before anything changes)
  each(order, function(host, next)
    ask(sup, host, { type = "package_status", name = name, system_dir = plan.system_dir }, function(r, err)
      if not r then finish(nil, sformat("stopped before any change: host %s: %s", host, err)) return end
      u.from[host] = r.loads and r.loads.version or ""
      next()
    end)
  end, function()
    u.version = core.package_version(data)
    M.say_plan(u)
    M.record(u, "rolling", nil, function()
      M.roll(u, finish)
    end)
  end)
end

-- The plan's lines: versions, the order, the leaves, the watch.
function M.say_plan(u)
  local parts = {}
  for i, h in ipairs(u.order) do
    parts[#parts + 1] = sformat("%s%s (%s, runs %s)", h, i == 1 and " [canary]" or "",
      u.plan.standby[h] and "a standby host" or concat(u.plan.leaves[h], ", "), short(u.from[h]))
  end
  u.say("plan: %d byte%s%s to %d host%s, leaf by leaf: %s; the canary watched %g s", #u.data,
    #u.data == 1 and "" or "s",
    u.version and " (version " .. short(u.version) .. ")" or "", #u.order, #u.order == 1 and "" or "s",
    concat(parts, ", then "), u.watch)
end

-- The configuration repository's record of the upgrade: upgrade.NAME, and packages.NAME.HOST of the hosts done.
-- Best effort: a repository that cannot be written is said, and the roll goes on.
function M.record(u, state, reason, k)
  local sup = u.sup
  if not sup.rt.config_client then k() return end
  local hosts = {}
  for h, v in pairs(u.done) do hosts[h] = v end
  local values = { ["upgrade." .. u.name] = { state = state, version = u.version or "", canary = u.canary,
                                              order = u.order, from = u.from, hosts = hosts, reason = reason,
                                              watch = u.watch, bytes = #u.data } }
  for h, v in pairs(u.done) do values["packages." .. u.name .. "." .. h] = v end
  sup.rt.config_client(function(c, err)
    if not c then u.say("not recorded in the configuration repository: %s", tostring(err)) k() return end
    c:set(values, function(r, serr)
      if not r then u.say("not recorded in the configuration repository: %s", tostring(serr)) end
      k()
    end)
  end)
end

-- Each host in order: installed, its leaves restarted; the canary watched. A failure rolls that host back.
function M.roll(u, finish)
  each(u.order, function(host, next)
    M.host(u, host, function(ok, reason)
      if ok then next() return end
      M.rollback(u, host, reason, finish)
    end)
  end, function()
    M.record(u, "done", nil, function()
      finish(true, sformat("done: %d host%s run version %s (%s)", #u.order, #u.order == 1 and "" or "s",
        short(u.version), concat(u.order, ", ")))
    end)
  end)
end

-- One host: install, restart its leaves one by one (watching them from the first), then the canary's watch.
-- cb(true) | cb(nil, reason)
function M.host(u, host, cb)
  local sup, leaves = u.sup, u.plan.leaves[host]
  local failed
  local function fail(reason)
    if failed then return end
    failed = reason
    sup.upgrade_tap = nil
    if u.timer then u.timer:cancel() u.timer = nil end
    cb(nil, reason)
  end
  ask(sup, host, { type = "package_install", name = u.name, data = u.data }, function(r, err)
    if not r then fail("install: " .. tostring(err)) return end
    u.version = r.version
    u.installed = host
    u.say("%s: installed version %s (was %s)%s", host, short(r.version), short(u.from[host]),
      r.unchanged and "; it was installed already" or "")
    -- the leaves and their groups watched from the first restart
    M.watch(u, sup, leaves)
    sup.upgrade_tap = function(line)
      local why = failure(u, line)
      -- (acted on from the loop: the line is being said in the middle of the supervisor's own handling)
      if why then sup.rt.after(0, function() fail(why) end) end
    end
    u.restarted = {}
    -- (a leaf in a shared node, --placement group|host, moves to a process of its own: the node cannot replace
    -- a package it loaded; a process the daemon starts now loads the installed version; restart.code_check)
    each(leaves, function(path, next)
      sup:restart(path, function(ok, how)
        if failed then return end
        if not ok then fail(sformat("restart of %s: %s", path, tostring(how))) return end
        u.restarted[#u.restarted + 1] = path
        u.say("%s: %s restarted (%d/%d)%s", host, path, #u.restarted, #leaves, how and ": " .. how or "")
        next()
      end, { own_process = true })
    end, function()
      if failed then return end
      if host ~= u.canary or u.watch == 0 then
        sup.upgrade_tap = nil
        u.done[host] = u.version
        cb(true)
        return
      end
      u.say("%s: watching the canary for %g s", host, u.watch)
      u.timer = sup.rt.after(u.watch, function()
        u.timer = nil
        if failed then return end
        sup.upgrade_tap = nil
        u.done[host] = u.version
        u.say("%s: the canary ran %g s with no crash or escalation", host, u.watch)
        cb(true)
      end)
    end)
  end)
end

-- Host `host` failed: the old file back (package_rollback), its restarted leaves restarted again onto it (a
-- leaf that is not running, e.g. its group escalated, is left to its group's policy and algebra: its next
-- process loads the old file), the repository told, the roll stopped.
function M.rollback(u, host, reason, finish)
  local sup = u.sup
  u.say("%s: failed: %s", host, reason)
  if u.installed ~= host then
    M.record(u, "failed", reason, function()
      finish(nil, sformat("stopped at %s before its install: %s", host, reason))
    end)
    return
  end
  ask(sup, host, { type = "package_rollback", name = u.name }, function(r, err)
    if not r then
      M.record(u, "failed", reason, function()
        finish(nil, sformat("stopped at %s; its rollback failed: %s", host, tostring(err)))
      end)
      return
    end
    u.say("%s: rolled back to %s", host, short(r.version ~= "" and r.version or u.from[host]))
    local again = {}
    for _, p in ipairs(u.plan.leaves[host]) do again[#again + 1] = p end
    each(again, function(path, next)
      sup:restart(path, function(ok, how)
        u.say("%s: %s %s", host, path,
          ok and "restarted onto the old version" or "left to its group: " .. tostring(how))
        next()
      end)
    end, function()
      u.done[host] = nil
      local untouched = {}
      for _, h in ipairs(u.order) do if not u.done[h] and h ~= host then untouched[#untouched + 1] = h end end
      M.record(u, "rolled back", reason, function()
        finish(nil, sformat("rolled back on %s and stopped%s: %s", host,
          #untouched > 0 and sformat(" (%s never received version %s)", concat(untouched, ", "), short(u.version))
            or "",
          reason))
      end)
    end)
  end)
end

M.failure = failure

return M
