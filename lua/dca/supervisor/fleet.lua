-- dca.supervisor.fleet: a group's templates, whose instances are added and removed while the system runs (OTP's
-- simple_one_for_one; docs/supervision.md, "A fleet"), as functions over the supervisor (sup). The supervisor
-- keeps the state; this module acts on it.
--
--   fleet.add(sup, path, host, cb)      -- an instance of the template at `path` on `host` (one of its hosts):
--                                       --   started (a group: its subtree up and wired), run at once when the
--                                       --   group runs. cb(true, instance path) | cb(nil, reason)
--   fleet.remove(sup, path, host, cb)   -- the instance at `path` (or, `path` a template, its instance on
--                                       --   `host`) stopped (actuators at zero) and ended for good. cb(true, path)
--   fleet.runs(sup, name)               --> whether child `name` is an instance the group runs now
--   fleet.owns(sup, name)               --> the template of child `name` (an instance), or nil
--   fleet.run_all(sup)                  -- the group's expression started: every instance up runs
--   fleet.stop_all(sup)                 -- the group's run ends (its outcome, an abort, an escalation): every
--                                       --   running instance is stopped, its stop acknowledged before the outcome
--   fleet.ended(sup, name, how, reason) -- an instance's end that its group's policy does not restart: said, and
--                                       --   never an event of the expression (instances are independent of it)
--   fleet.list(sup)                     --> { { template, path, type, hosts = {...}, instances = { {name, path,
--                                       --   host, state} ... } } ... } (tree(), the console's fleet())
--   fleet.here(sup, path)               --> the template of this group that `path` is or is an instance of, or nil
--
-- What an instance is (the contract the verifier relies on: dca.verify, docs/verify.md):
--   - a child of the group like any other once added: in `spec.children` (so tree(), restarts, the policy's
--     plan, shutdown and failover see it), its supervisor's or node's faults the group's policy's;
--   - never named in the expression, never connected (dca.lang.check refuses both): it runs from when it is added
--     (or the group runs) until it is removed or the group's run ends; its DONE or an ABORTED the policy does not
--     restart ends that instance only;
--   - added on one host of its template's set, at most one instance per host, named `<template>_<host>`
--     (dca.lang.model.instance_name), its host the type's first argument.
-- The group tells its parent of each change (`fleet` {path, instance, added | removed}): a parent that restarts
-- the group starts a fresh supervisor with the instances it had (`spec.templates[i].added`). It records each change
-- in the configuration repository of its host, replicated to every host, before it answers: `fleet.PATH` = { hosts
-- = { host with an instance, in the order they joined... }, last = { what, instance } }, one transaction each.
local M = {}

local async = require "dca.async"
local child = require "dca.supervisor.child"
local spec_mod = require "dca.supervisor.spec"
local wiring = require "dca.supervisor.wiring"

local ipairs, tostring, sformat, concat = ipairs, tostring, string.format, table.concat

-- The template of this group at `path`, or the one `path` is an instance of, and the instance's name (or nil).
function M.here(sup, path)
  for _, t in ipairs(sup.spec.templates or {}) do
    if t.path == path then return t end
    for _, c in ipairs(t.instances) do
      if c.path == path then return t, c.name end
    end
  end
end

function M.owns(sup, name)
  return sup.fleet_of and sup.fleet_of[name]
end

function M.runs(sup, name)
  return sup.fleet_running ~= nil and sup.fleet_running[name] == true
end

local function hosts_text(t) return concat(t.hosts, ", ") end

-- The prepared instance of template `t` on `host` (t.instances[i] is the one on t.hosts[i]), or nil and why not.
local function prepared(t, host)
  for i, h in ipairs(t.hosts) do
    if h == host then return t.instances[i] end
  end
  return nil, sformat("%s: host %s is not one of its hosts (%s)", t.path, tostring(host), hosts_text(t))
end

-- The spec child `c` taken into the group (its record made), or out of it.
local function enter(sup, t, c)
  local entry = spec_mod.copy(c)
  sup.spec.children[#sup.spec.children + 1] = entry
  local ch = child.new(entry)
  sup.children[entry.name] = ch
  sup.fleet_of = sup.fleet_of or {}
  sup.fleet_of[entry.name] = t.name
  return ch
end

local function leave(sup, name)
  for i, c in ipairs(sup.spec.children) do
    if c.name == name then table.remove(sup.spec.children, i) break end
  end
  for i, n in ipairs(sup.order) do
    if n == name then table.remove(sup.order, i) break end
  end
  sup.children[name] = nil
  sup.fleet_of[name] = nil
  if sup.fleet_running then sup.fleet_running[name] = nil end
end

-- The template's hosts that have an instance, in the order they were added.
local function members(sup, t)
  local hosts = {}
  for _, name in ipairs(t.added or {}) do
    local ch = sup.children[name]
    if ch then hosts[#hosts + 1] = ch.host end
  end
  return hosts
end

-- The configuration repository's record of the template (`fleet.PATH`: its hosts with an instance, in the order
-- they joined, and the change), one transaction per change, written before the change is answered. Best effort:
-- a repository that cannot be written is said, and the change stands. k()
local function record(sup, t, name, what, k)
  if not sup.rt.config_client then k() return end
  local value = { hosts = members(sup, t), last = { what = what, instance = name } }
  sup.rt.config_client(function(c, err)
    if not c then sup:say("%s: not recorded in the configuration repository: %s", t.path, tostring(err)) k() return end
    c:set({ ["fleet." .. t.path] = value }, function(r, serr)
      if not r then sup:say("%s: not recorded in the configuration repository: %s", t.path, tostring(serr)) end
      k()
    end)
  end)
end

-- The group's record of its instances, which its parent keeps too (a restarted group starts them again), and
-- the repository's. k()
local function note(sup, t, name, what, k)
  t.added = t.added or {}
  if what == "added" then t.added[#t.added + 1] = name
  else
    for i, n in ipairs(t.added) do if n == name then table.remove(t.added, i) break end end
  end
  sup.rt.report({ type = "fleet", path = t.path, instance = name, what = what })
  record(sup, t, name, what, k)
end

-- A `fleet` event from the child group `ch`: its spec (what a restart of it starts) follows the change.
function M.child_changed(sup, ch, msg)
  local g = ch.spec and ch.spec.spec
  for _, t in ipairs(g and g.templates or {}) do
    if t.path == msg.path then
      t.added = t.added or {}
      if msg.what == "added" then t.added[#t.added + 1] = msg.instance
      else
        for i, n in ipairs(t.added) do if n == msg.instance then table.remove(t.added, i) break end end
      end
    end
  end
end

-- Runs instance `name` when the group runs (with the group's last init).
local function run_one(sup, name)
  if sup.state ~= "running" then return end
  sup.fleet_running = sup.fleet_running or {}
  sup.fleet_running[name] = true
  sup:_start_child(name, sup.last_init)
end

function M.add(sup, path, host, cb)
  local t = M.here(sup, path)
  if not t or t.path ~= path then cb(nil, sformat("%s has no template '%s'", sup.path, tostring(path))) return end
  local c, why = prepared(t, host)
  if not c then cb(nil, why) return end
  if sup.children[c.name] then cb(nil, sformat("%s already has an instance on host %s: %s", t.path, host, c.path)) return end
  if sup.shutdown_waiters or not (sup.state == "running" or sup.state == "configured" or sup.state == "starting") then
    cb(nil, sformat("%s: cannot add an instance while its group is %s", t.path, sup.state))
    return
  end
  local ch = enter(sup, t, c)
  sup:say("%s: adding %s on host %s", t.path, ch.path, tostring(host))
  local function failed(err)
    -- whatever started of it is ended; the group goes on without it
    local h = ch.handle
    ch.handle = nil
    if ch.state ~= "gone" then child.set(ch, "gone") end
    leave(sup, ch.name)
    if h then h.kill("KILL") end
    sup:say("%s: not added: %s", ch.path, tostring(err))
    cb(nil, err)
  end
  sup:_start_one(ch, function(ok, err)
    if not ok then failed(err) return end
    if sup.children[ch.name] ~= ch then cb(nil, ch.path .. ": removed while it started") return end
    -- a leaf's device ports wired to the world, as a restart of it does
    local function wired(wok, werr)
      if not wok then failed(werr) return end
      sup:say("%s: added on host %s", ch.path, tostring(host))
      run_one(sup, ch.name)
      note(sup, t, ch.name, "added", function() cb(true, ch.path) end)
    end
    if ch.kind == "leaf" then wiring.devices(sup, wired, ch.path) else wired(true) end
  end, function() return false end)
end

-- Stops instance `ch` (a running leaf: stop, actuators at zero; a group: its subtree shut down) and ends its
-- process. cb()
local function stop(sup, ch, cb)
  local h = ch.handle
  ch.handle = nil
  child.set(ch, "gone")
  if not h then cb() return end
  local function kill() h.kill("TERM", function(ok, err)
    if not ok then sup:log("%s: end of %s: %s", sup.path, ch.path, tostring(err)) end
    cb()
  end) end
  if ch.kind == "group" then h.request({ type = "shutdown" }, sup.timeouts.shutdown, kill)
  else h.request({ type = "stop" }, sup.timeouts.stop, kill) end
end

function M.remove(sup, path, host, cb)
  local t, name = M.here(sup, path)
  if t and not name and host ~= nil then
    local c = prepared(t, host)
    name = c and c.name
  end
  local ch = name and sup.children[name]
  if not (t and ch) then
    cb(nil, sformat("%s: no instance %s", sup.path, tostring(path) .. (host and (" on host " .. tostring(host)) or "")))
    return
  end
  if ch.restart then cb(nil, ch.path .. " is being restarted: remove it once it is up") return end
  sup:say("%s: removing", ch.path)
  if sup.fleet_running then sup.fleet_running[name] = nil end
  stop(sup, ch, function()
    leave(sup, name)
    sup:say("%s: removed", ch.path)
    note(sup, t, name, "removed", function() cb(true, ch.path) end)
  end)
end

function M.run_all(sup)
  for _, c in ipairs(sup.spec.children) do
    local ch = sup.children[c.name]
    if M.owns(sup, c.name) and ch.handle and (ch.state == "inactive" or ch.state == "done" or ch.state == "aborted") then
      run_one(sup, c.name)
    end
  end
end

function M.stop_all(sup)
  if not sup.fleet_running then return end
  local names = {}
  for i = #sup.order, 1, -1 do
    local n = sup.order[i]
    if sup.fleet_running[n] then names[#names + 1] = n end
  end
  sup.fleet_running = {}
  for _, n in ipairs(names) do
    local ch = sup.children[n]
    if ch and (ch.state == "running" or ch.state == "inactive") then sup:_abort_child(n) end
  end
end

function M.ended(sup, name, how, reason)
  local ch = sup.children[name]
  if sup.fleet_running then sup.fleet_running[name] = nil end
  if how == "done" then sup:say("%s: done %s (its instance ends; the group runs on)", ch.path, tostring(reason))
  else sup:say("%s: %s: %s (not restarted: its instance ends; the group runs on)", ch.path, how, tostring(reason)) end
end

-- A fresh supervisor of this group: the instances its earlier one had (spec.templates[i].added) come up with
-- it, started as the start protocol's last step. k(true) | k(nil, reason)
function M.restore(sup, k)
  local todo = {}
  for _, t in ipairs(sup.spec.templates or {}) do
    for _, name in ipairs(t.added or {}) do
      for i, c in ipairs(t.instances) do
        if c.name == name then todo[#todo + 1] = { t = t, host = t.hosts[i] } end
      end
    end
    t.added = {}
  end
  async.each_in_order(todo, function(x, _, next)
    M.add(sup, x.t.path, x.host, function(ok, err)
      if not ok then k(nil, err) return end
      next()
    end)
  end, function() k(true) end)
end

function M.list(sup)
  local out = {}
  for i, t in ipairs(sup.spec.templates or {}) do
    local l = { template = t.name, path = t.path, type = t.type, hosts = t.hosts, instances = {} }
    for _, c in ipairs(t.instances) do
      local ch = sup.children[c.name]
      if ch and M.owns(sup, c.name) then
        l.instances[#l.instances + 1] = { name = c.name, path = c.path, host = ch.host, state = ch.state }
      end
    end
    out[i] = l
  end
  return out
end

return M
