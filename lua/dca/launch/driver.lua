-- dca.launch.driver: a robot's driver as the robot of a run, in wall-clock time (docs/drivers.md): `dca run FILE
-- --driver 'TYPE(HOST, ARGS...)'`. The driver is a controller (of a package, or built in), written as an instance
-- in a .dca file is, and checked as one is. Its manifest's ports are the robot's signals: the leaves' device ports
-- are checked against them, and wired to them as to `dca sim`'s. It runs in `dca node --name world` on HOST,
-- started and run (init, run) before the tree, stopped after it. Its ABORTED or its exit ends the run as the
-- loss of the world does.
--
--   local driver = require "dca.launch.driver"
--   local d, err = driver.read(expr, file)  -- d.leaf { type, host, args, package }, d.dir, d.text, d.signals (as
--                                           -- core.world_signals gives them) | nil, err (exit code 2)
--   driver.start(ctx, cb)                   -- with ctx.o.driver (a read driver): ctx.driver, a dca.clients.world
--                                           -- client on it, once it runs. cb(true) | cb(nil, err)
--   driver.stop(ctx, cb)                    -- stop, then exit (bounded); cb() once it is gone
--   driver.estop(ctx, req, t, cb)            -- the emergency stop (docs/safety.md): req {type = "estop" |
--                                           -- "release", source}: the driver stopped (its on_halt leaves the
--                                           -- robot safe) or run again; cb(reply {t, already, source}, event)
--                                           -- | cb(nil, err)
local world_client = require "dca.clients.world"

local M = {}

local ipairs, tostring, sformat = ipairs, tostring, string.format

-- The manifest's ports as a world's signals: { [name] = port }.
local function by_name(ports)
  local out = {}
  for _, p in ipairs(ports or {}) do out[p.name] = p end
  return out
end

-- The source the driver's expression is checked in: an instance `world` of a file in FILE's folder (so that its
-- package is found there too), on a line of its own.
local function source(expr)
  local pkg = expr:match("^%s*([%a_][%w_]*)%.[%a_]")
  return (pkg and ("use " .. pkg .. "; ") or "") .. "process main() { instantiated_processes {\n" ..
    "world instof " .. expr .. ";\n} internal_event_actions { world } }\n"
end

--- The driver `expr` ("TYPE(HOST, ARGS...)") of a run of `file`, read and checked. --> d | nil, err
function M.read(expr, file)
  local core = require "dca.core"
  local dir = core.absolute(tostring(file)):match("^(.*)/[^/]*$") or "."
  local path = dir .. "/--driver"
  local ast, tree = require("dca.load").text(source(expr), path, { root = "main", world = false })
  if not ast then
    -- the errors name the pseudo-file: said as the option, at the column in the expression
    local at = path:gsub("%p", "%%%0")
    local text = tostring(tree):gsub(at .. ":2:(%d+):", function(col)
      return sformat("--driver:1:%d:", math.max(1, tonumber(col) - #"world instof "))
    end):gsub(at, "--driver")
    return nil, "--driver " .. expr .. ":\n" .. text
  end
  local leaf = require("dca.supervisor.spec").from_model(tree, path).children[1]
  local m = core.types()[leaf.type]
  if not m then return nil, sformat("--driver %s: no manifest for type %s", expr, tostring(leaf.type)) end
  return { leaf = leaf, dir = dir, text = expr,
           signals = { outputs = by_name(m.outputs), inputs = by_name(m.inputs) } }
end

--- The argv of the driver's node on the daemon at `addr`: `dca node --type TYPE --name world ...`.
function M.argv(d, addr, key)
  local l = d.leaf
  return require("dca.supervisor.net").child_argv({ kind = "leaf", type = l.type, path = "world", args = l.args,
    package = l.package, system_dir = l.package and d.dir or nil }, addr, key)
end

--- With ctx.o.driver: its node started on its host, reached, initialised and run. ctx.driver is its client (a
--- dca.clients.world client: request, stop, on_lost). cb(true) | cb(nil, err)
function M.start(ctx, cb)
  local d = ctx.o.driver
  if not d then cb(true) return end
  local host = d.leaf.host
  if not ctx.hosts[host] then
    local err = sformat("--driver %s: host %s is not a host of the system (%s)", d.text, tostring(host),
      table.concat(ctx.names, ", "))
    require("dca.core").after(0, function() cb(nil, err) end)  -- from the loop, which then stops
    return
  end
  local what = sformat("the driver %s on host %s", d.text, host)
  local w = world_client.new{ daemon = ctx.hosts[host], host = host, key = ctx.key, wait = ctx.o.wait,
    log = ctx.daemons and ctx.daemons.logs[host], argv = M.argv(d, ctx.hosts[host], ctx.key), what = what,
    said = "dca node: ", class = require("dca.clients.node").Client }
  ctx.driver = w
  ctx.say(sformat("driver: starting %s as the robot (world), in wall-clock time", what))
  w:start(function(ok, err)
    if not ok then cb(nil, err) return end
    local function ended(how) if w.on_lost then w.on_lost(what .. " ended " .. how) end end
    w.client:on_aborted(function(reason) ended("ABORTED: " .. tostring(reason)) end)
    w.client:on_done(function(value) ended("DONE " .. tostring(value)) end)
    w.client:init(function(r, ierr)
      if not r then cb(nil, what .. ": init: " .. tostring(ierr)) return end
      w.client:run(nil, function(r2, rerr)
        if not r2 then cb(nil, what .. ": run: " .. tostring(rerr)) return end
        ctx.say("driver: running")
        cb(true)
      end)
    end)
  end)
end

-- "1 0 2" for a sample's value (a vector, or a number)
local function show(v)
  if type(v) ~= "table" then return tostring(v) end
  local parts = {}
  for i, x in ipairs(v) do parts[i] = sformat("%.15g", x) end
  return table.concat(parts, " ")
end

--- The driver's counts, said (ctx.say): its outputs named safety.* and device.* (docs/drivers.md), as they are
--- now. k() after.
function M.say_counts(ctx, k)
  local w, names = ctx.driver, {}
  for name in pairs(ctx.o.driver.signals.outputs) do
    if name:find("^safety%.") or name:find("^device%.") then names[#names + 1] = name end
  end
  table.sort(names)
  require("dca.async").each_in_order(names, function(name, _, next)
    w.client:read(name, function(r)
      if r and r.count and r.count > 0 then ctx.say(sformat("driver: %s = %s", name, show(r.value))) end
      next()
    end)
  end, k)
end

--- The emergency stop on the driver's robot at `t` (s since the run's start): pressed, its controller stopped
--- (halt: the base zeroes its actuator outputs, its on_halt leaves the robot safe, rule 12); released, it is
--- initialised and run again. cb(reply, event | nil) | cb(nil, err)
function M.estop(ctx, req, t, cb)
  local w = ctx.driver
  if not (w and w:connected()) then cb(nil, "no robot to stop: the driver is not connected") return end
  local st = ctx.driver_estop or { latched = false }
  ctx.driver_estop = st
  if req.type == "estop" and st.latched then cb({ t = st.t, already = true, source = st.source }) return end
  if req.type == "release" and not st.latched then cb(nil, "release: the emergency stop is not pressed") return end
  local function changed(latched)
    st.latched, st.t, st.source = latched, t, tostring(req.source)
    cb({ t = t, source = st.source }, { latched = latched, t = t, source = st.source })
  end
  if req.type == "estop" then
    st.latched = true  -- at once: a second press while the stop is on its way is no new one
    w.client:stop(function(r, err)
      if not r then ctx.say("driver: emergency stop: its stop failed: " .. tostring(err)) end
      changed(true)
    end)
    return
  end
  w.client:init(function(r, err)
    if not r then cb(nil, "release: the driver's init: " .. tostring(err)) return end
    w.client:run(nil, function(r2, rerr)
      if not r2 then cb(nil, "release: the driver's run: " .. tostring(rerr)) return end
      changed(false)
    end)
  end)
end

--- The driver's counts said, the driver stopped (its on_halt leaves the robot safe), then its process ended
--- (bounded). cb(), once; a second call waits for the first's end.
function M.stop(ctx, cb)
  local w = ctx.driver
  if not w then cb() return end
  if w.stop_waiters then table.insert(w.stop_waiters, cb) return end
  w.stop_waiters, w.stopping = { cb }, true
  local function gone() for _, k in ipairs(w.stop_waiters) do k() end end
  if not w:connected() then w:stop(gone) return end
  M.say_counts(ctx, function() w.client:stop(function() w:stop(gone) end) end)
end

return M
