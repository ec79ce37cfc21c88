-- dca.launch.start: the one start-up sequence of a system, shared by `dca run` (cli/run.lua), `dca scenario`
-- (dca.scenario.real) and, for its tree only (start.tree), a group's supervisor (launch/group.lua). Named
-- steps over one context, run in this order by start.sequence:
--
--   hosts      the daemons: a hosts file (o.hosts), or one fresh local daemon per host name (a fresh key)
--   config     the configuration repository: the defaults file and o.set, on the root's host, replicated
--   tree       the root supervisor (dca.supervisor) on the network runtime (dca.supervisor.net)
--   sim_clock  with o.sim and a hosts file: every daemon is on the simulated clock
--   world      with o.sim: the world process (dca.launch.sim) through o.world_host (default the first host)
--   driver     with o.driver: a robot's driver as the world, in wall-clock time (dca.launch.driver)
--
-- then the tree's own start (sup:configure) and run. A step returns true or nil, err (and a kind of error);
-- sim_clock and world wait on the network, so start.sequence runs the steps in a coroutine that each such
-- wait suspends: the sequence reads top to bottom and ends in cb(true) or cb(nil, err, step, kind).
--
--   local ctx = start.context(spec, o, { say = fn(line), report = fn(msg), log = fn(line) })
--   start.sequence(ctx, { "hosts", "config" }, cb)   -- (cb at once: neither waits)
--   local sup = start.tree(ctx, daemon_host, opts)
--   start.sequence(ctx, { "sim_clock", "world" }, function(ok, err, step, kind) ... end)
--   start.cleanup(ctx, keep)                  -- the world's channels, the runtime, the daemons, the key dir
--                                             --   (keep: the daemons' logs kept first; --> their folder)
local config, console = require "dca.config", require "dca.supervisor.console"
local supervisor, net = require "dca.supervisor", require "dca.supervisor.net"
local hosts_mod, sim = require "dca.launch.hosts", require "dca.launch.sim"
local async = require "dca.async"

local M = {}

local ipairs, sformat = ipairs, string.format

--- The context of a start: spec, options `o` (hosts, state_dir, config, set, check, fresh_key, sim = the
--- world's name, world_host, and the world's own options: dca.clients.world.OPTIONS) and the hooks say(line),
--- report(msg), log(line).
function M.context(spec, o, hooks)
  return { spec = spec, o = o, names = require("dca.supervisor.spec").hosts(spec), exe = hosts_mod.self_exe(),
           say = hooks.say or function() end, report = hooks.report, log = hooks.log }
end

--- The daemons: ctx.hosts = { name = addr }; with local daemons also ctx.daemons, ctx.key, ctx.keydir.
function M.hosts(ctx)
  local o = ctx.o
  ctx.key = o.key or os.getenv("DCA_KEY_FILE")
  if o.hosts then
    local hosts, err = hosts_mod.read_file(o.hosts)
    if not hosts then return nil, err end
    ctx.hosts = hosts
  else
    if not ctx.key or o.fresh_key then ctx.key, ctx.keydir = hosts_mod.fresh_key() end
    -- the key dir (the daemons' logs too) goes with the daemons when `dca run` cannot remove it (killed)
    local set, err, kind = hosts_mod.start_local(ctx.names, { exe = ctx.exe, key = ctx.key, clock = o.sim and "sim" or nil,
      log_dir = ctx.keydir or os.getenv("TMPDIR") or "/tmp", state_dir = o.state_dir, remove_on_exit = { ctx.keydir } })
    if not set then return nil, err, kind end
    ctx.daemons, ctx.hosts = set, set.hosts
    for _, name in ipairs(ctx.names) do
      ctx.say(sformat("host %s: daemon at %s (pid %d)", name, set.hosts[name], set.pids[name]))
    end
  end
  for _, h in ipairs(ctx.names) do
    if not ctx.hosts[h] then return nil, sformat("no daemon for host '%s' in %s", h, tostring(o.hosts)) end
  end
  return true
end

--- The configuration repository: the defaults file (o.config) and o.set written on the root's host and
--- replicated to the others; with o.check every config("key") parameter is read once (all errors listed).
--- nil, err, "file" when the defaults file is wrong.
function M.config(ctx)
  local used = {}
  for _, h in ipairs(ctx.names) do used[h] = ctx.hosts[h] end
  local spec, o = ctx.spec, ctx.o
  local origin = (spec.host and used[spec.host]) and spec.host or ctx.names[1]
  local line, err = config.seed_run(used, origin, { key_file = ctx.key, file = o.config, set = o.set })
  if err then return nil, err, o.config and err:find(o.config, 1, true) == 1 and "file" or nil end
  if line then ctx.say(line) end
  if not o.check then return true end
  local ok, kerr = config.check_spec(used, origin, spec, { key_file = ctx.key })
  if not ok then return nil, kerr, "params" end
  return true
end

--- With o.sim, the world first (the nodes on the simulated clock find it when they start): ctx.sim (a
--- dca.launch.sim) once it is registered. cb(true) | cb(nil, err)
function M.world(ctx, cb)
  local o = ctx.o
  if not o.sim then cb(true) return end
  local wh = o.world_host or ctx.names[1]
  if not ctx.hosts[wh] then cb(nil, "world_host " .. tostring(wh) .. " is not a host of the system") return end
  ctx.world_host = wh
  local wo = { daemon = ctx.hosts[wh], host = wh, key = ctx.key, log = ctx.daemons and ctx.daemons.logs[wh] }
  for _, k in ipairs(require("dca.clients.world").OPTIONS) do wo[k] = o[k] end
  wo.world = o.sim
  ctx.sim = sim.new(wo, o.summary and ctx.spec or nil)
  ctx.say(sformat("world: starting `dca sim --serve --world %s` on host %s", o.sim, wh))
  ctx.sim.world:start(function(ok, err)
    if not ok then cb(nil, err) return end
    ctx.say("world: ready; time stands at 0 until the root runs")
    cb(true)
  end)
end

--- The supervisor of ctx.spec on the network runtime over ctx.hosts (the root of `dca run` and scenarios, or a
--- group's in `dca supervise`); its own host (configuration, world lookups) is `daemon_host` (nil: the first
--- host). opts: progress (default true), timeouts, placement (default ctx.o.placement, else "process": where
--- the leaves run, dca.supervisor.net). --> sup (also ctx.sup, ctx.rt)
function M.tree(ctx, daemon_host, opts)
  opts = opts or { progress = true }
  local placement = opts.placement or (ctx.o and ctx.o.placement)
  local rt = net.new({ hosts = ctx.hosts, key = ctx.key, exe = ctx.exe, daemon_host = daemon_host,
                       timeouts = opts.timeouts, report = ctx.report, log = ctx.log, placement = placement,
                       to_parent = ctx.to_parent })
  local sup = supervisor.new(ctx.spec, rt, { progress = opts.progress, timeouts = opts.timeouts, hosts = ctx.hosts,
                                             console = console.hook, placement = placement })
  sup.hosts = ctx.hosts
  rt.bind(sup)
  ctx.rt, ctx.sup = rt, sup
  return sup
end

--- With o.sim and a hosts file: every daemon must be on the simulated clock (its ping says so). cb(true) |
--- cb(nil, err naming each host that is not)
function M.sim_clock(ctx, cb)
  if not (ctx.o.sim and ctx.o.hosts) then cb(true) return end
  local daemon_client = require "dca.clients.daemon"
  local bad = {}
  local j = async.join(function()
    if #bad > 0 then cb(nil, "--sim needs every daemon on the simulated clock: " .. table.concat(bad, "; "))
    else cb(true) end
  end)
  for _, h in ipairs(ctx.names) do
    local k = j.add()
    local function one(reason)
      if reason then bad[#bad + 1] = reason end
      k(true)
    end
    daemon_client.connect(ctx.hosts[h], require("dca.clients").key_opts(ctx.key), function(d, err)
      if not d then one(sformat("host %s at %s: %s", h, ctx.hosts[h], tostring(err))) return end
      d:request({ type = "ping" }, 10, function(r, perr)
        d:close()
        if not r then one(sformat("host %s: %s", h, tostring(perr)))
        elseif r.clock ~= "sim" then
          one(sformat("the daemon of host %s runs on the %s clock (start it with --clock sim)", h,
            tostring(r.clock or "wall")))
        else one(nil) end
      end)
    end)
  end
  j.close()
end

--- With o.driver, the robot's driver first, as the world (dca.launch.driver). cb(true) | cb(nil, err)
function M.driver(ctx, cb) require("dca.launch.driver").start(ctx, cb) end

-- The steps that wait on the network: step(ctx, cb) calls back cb(true) | cb(nil, err).
local WAITS = { sim_clock = true, world = true, driver = true }

-- Runs step `name` to its end, suspending the running coroutine while it waits. --> ok, err, kind
local function run_step(ctx, name)
  if not WAITS[name] then return M[name](ctx) end
  local co, res, waiting = coroutine.running(), nil, false
  M[name](ctx, function(...)
    if res then return end                    -- a second call: the step has already ended
    res = table.pack(...)
    if waiting then
      local ok, err = coroutine.resume(co)
      if not ok then error(debug.traceback(co, err), 0) end
    end
  end)
  if not res then waiting = true coroutine.yield() end
  return table.unpack(res, 1, res.n)
end

--- Runs the named steps in order; cb(true) after the last, cb(nil, err, step, kind) at the first that fails.
function M.sequence(ctx, names, cb)
  local co = coroutine.create(function()
    for _, name in ipairs(names) do
      -- a stop signal held since main (bindings/stop_signals.h) ends the start between any two steps
      local sig = require("dca.core").pending_signal()
      if sig then return cb(nil, "interrupted (SIG" .. sig .. ")", name, "signal") end
      local ok, err, kind = run_step(ctx, name)
      if not ok then return cb(nil, err, name, kind) end
    end
    cb(true)
  end)
  local ok, err = coroutine.resume(co)
  if not ok then error(debug.traceback(co, err), 0) end
end

-- The local daemons' logs (each one's output and its children's) copied out of the key dir, which goes, into
-- a fresh folder under $DCA_RUN_LOGS (default $TMPDIR, else /tmp). --> its path | nil, err
local function keep_logs(ctx)
  local core = require "dca.core"
  local under = os.getenv("DCA_RUN_LOGS") or os.getenv("TMPDIR") or "/tmp"
  core.make_dir(under)  -- (it may exist)
  local dir = sformat("%s/dca-run-logs-%s-%d", under, os.date("%Y%m%d-%H%M%S"), hosts_mod.self_pid() or 0)
  local ok, err = core.make_dir(dir)
  if not ok then return nil, err end
  for _, name in ipairs(ctx.names) do
    local f = io.open(ctx.daemons.logs[name] or "", "rb")
    if f then
      core.write_new_file(sformat("%s/%s.log", dir, name), f:read("a"))
      f:close()
    end
  end
  return dir
end

--- Everything the start opened, closed: the root daemon's registration channel, the runtime, the world's
--- channels, the local daemons, the key dir. With `keep` (a failed run) the local daemons' logs are kept first,
--- in a folder of their own (the key goes). --> that folder's path | nil, err (none kept)
function M.cleanup(ctx, keep)
  if ctx.rt and ctx.rt.root_daemon then ctx.rt.root_daemon:close() end
  if ctx.rt then ctx.rt.close() end
  if ctx.sim then ctx.sim.world:close() end
  if ctx.driver then ctx.driver:close() end
  if ctx.daemons then ctx.daemons:stop() end
  local kept, err
  if keep and ctx.daemons and ctx.keydir then kept, err = keep_logs(ctx) end
  if ctx.keydir then require("dca.core").remove_tree(ctx.keydir) ctx.keydir = nil end
  return kept, err
end

return M
