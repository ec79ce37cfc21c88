-- dca.supervisor.net: the real runtime of a supervisor, over `dca.core` channels and the hosts' daemons.
--
-- argv[1] is "dca": the daemon starts its own executable (its allow-list admits `dca node|supervise|sim`).
-- Leaves start as `dca node --type T --name PATH --daemon ADDR -- ARGS` and sub-groups as
-- `dca supervise --name PATH --daemon ADDR`, each by the daemon (Executer) of its host; the supervisor then
-- looks the new process up by its path (NameServer) and opens a channel to its `control` endpoint.
-- Exit events from a daemon and closed channels become child_exit(name, reason) on the owning supervisor.
--
--   local rt = require("dca.supervisor.net").new{ hosts = { h1 = "127.0.0.1:7001" }, key = FILE, exe = DCA,
--                                                report = function(msg) end, log = function(line) end }
--   rt.bind(sup)           -- the supervisor whose children this runtime starts (after supervisor.new)
--   rt.reply(ch, req, msg) -- answers a request that arrived on a channel
local core = require "dca.core"
local config = require "dca.config"

local M = {}

local ipairs, pairs, type, tostring, sformat, tonumber = ipairs, pairs, type, tostring, string.format, tonumber
local concat = table.concat

--- Answers the request number `id` (received on channel `ch`) with `msg`: {type = "ok", ...} or
--- {type = "error", reason = "..."}.
function M.reply(ch, id, msg)
  if not id or id == 0 then return false end
  if msg.type == "error" then return ch:reply_error(id, tostring(msg.reason)) end
  local payload = {}
  for k, v in pairs(msg) do if k ~= "type" then payload[k] = v end end
  return ch:reply(id, payload)
end

--- The requests a console (`dca repl`) may send to a supervisor.
M.CONSOLE = { repl = true, complete = true, tree = true, inject = true, restart = true, switch = true,
              stats = true, ping = true }

--- Answers one request `msg` (number `id`) of a console channel `ch` on supervisor `sup` (nil: not configured
--- yet). `follow {}` subscribes the channel to the transition lines in `followers` (a set of channels).
function M.console(ch, id, msg, sup, followers)
  if (id or 0) == 0 then return end
  if msg.type == "follow" then
    followers[ch] = true
    return M.reply(ch, id, { type = "ok" })
  end
  if not M.CONSOLE[msg.type] then
    return M.reply(ch, id, { type = "error", reason = "a console may send " ..
      "repl, complete, tree, inject, restart, switch, stats, ping or follow, not '" .. tostring(msg.type) .. "'" })
  end
  if not sup then return M.reply(ch, id, { type = "error", reason = "the supervisor is not configured yet" }) end
  sup:handle(msg, function(r) M.reply(ch, id, r) end)
end

--- Sends a transition line to every following console (closed ones are dropped). --> how many got it
function M.to_followers(followers, line)
  local n = 0
  for ch in pairs(followers) do
    if ch:is_open() then ch:send({ type = "log", line = line }) n = n + 1 else followers[ch] = nil end
  end
  return n
end

--- Connection options for `core.connect`/`core.listen` from a key file path (nil: dca.core's default).
function M.key_opts(key_file)
  return { key_file = key_file }
end

local SIGNAMES = { [1] = "HUP", [2] = "INT", [3] = "QUIT", [4] = "ILL", [6] = "ABRT", [7] = "BUS", [8] = "FPE",
                   [9] = "KILL", [11] = "SEGV", [13] = "PIPE", [14] = "ALRM", [15] = "TERM" }
function M.describe_exit(msg, host)
  if msg.signal then
    local s = tonumber(msg.signal) and SIGNAMES[tonumber(msg.signal)] or tostring(msg.signal)
    return sformat("killed by SIG%s on host %s", tostring(s):gsub("^SIG", ""), host)
  end
  return sformat("exited with code %s on host %s", tostring(msg.code), host)
end

local function argstr(v)
  if type(v) == "number" then
    if math.type(v) == "integer" then return tostring(v) end
    return sformat("%.17g", v)
  end
  return tostring(v)
end

function M.new(opts)
  local rt = { opts = opts, daemons = {}, by_child = {}, closing = false }
  local sup
  local timeouts = opts.timeouts or { spawn = 10, lookup = 10 }

  function rt.bind(s) sup = s end
  function rt.now() return core.now() end
  function rt.defer(fn) return core.after(0, fn) end
  function rt.after(s, fn) return core.after(s, fn) end
  function rt.every(s, fn) return core.every(s, fn) end
  function rt.report(msg) if opts.report then opts.report(msg) end end
  function rt.log(line) if opts.log then opts.log(line) end end

  --- The heartbeat period and the silence after which a daemon or a child supervisor is lost (seconds):
  --- opts.heartbeat = { period, timeout }, default 1 and 5 (generous: a loaded machine answers late, a
  --- stopped process never).
  function rt.heartbeat()
    local hb = opts.heartbeat or {}
    return hb.period or hb[1] or 1, hb.timeout or hb[2] or 5
  end

  -- A child process is gone (its exit event, or its host lost): whoever waits for it hears it once.
  function rt._gone(rec)
    if rec.kill_timer then rec.kill_timer:cancel() rec.kill_timer = nil end
    local waiters = rec.on_exit
    rec.on_exit = nil
    for _, w in ipairs(waiters or {}) do w(true) end
  end

  -- Every child on `host` is lost (its daemon closed or stopped answering).
  function rt._host_lost(host, reason)
    for _, rec in pairs(rt.by_child) do
      if rec.host == host then
        if not rec.exited then
          rec.exited = true
          if rec.lost_timer then rec.lost_timer:cancel() end
          if sup and not rt.closing then sup:child_exit(rec.name, reason) end
          if rec.ch and not rec.ch_closed then rec.ch:close() end
        end
        rt._gone(rec)
      end
    end
  end

  -- The channel to the daemon of `host` (opened once; its loss loses every child on that host).
  local function daemon(host, cb)
    local d = rt.daemons[host]
    if d and d.ch then cb(d.ch) return end
    if d then d.waiters[#d.waiters + 1] = cb return end
    local addr = opts.hosts[host]
    if not addr then cb(nil, sformat("no daemon for host '%s' (hosts: %s)", tostring(host),
      concat((function() local t = {} for k in pairs(opts.hosts) do t[#t + 1] = k end table.sort(t) return t end)(), ", ")))
      return
    end
    d = { waiters = { cb }, children = {} }
    rt.daemons[host] = d
    core.connect(addr, M.key_opts(opts.key), function(ch, err)
      local waiters = d.waiters
      d.waiters = {}
      if not ch then
        rt.daemons[host] = nil
        for _, w in ipairs(waiters) do w(nil, sformat("daemon of host %s at %s: %s", host, addr, tostring(err))) end
        return
      end
      d.ch = ch
      ch:on_message(function(msg)
        if d.config and d.config:event(msg) then return end
        if msg.type == "exit" then
          local rec = rt.by_child[host .. ":" .. tostring(msg.child)]
          if rec and not rec.exited then
            rec.exited = true
            if rec.lost_timer then rec.lost_timer:cancel() end
            if sup then sup:child_exit(rec.name, M.describe_exit(msg, host)) end
            if rec.ch and not rec.ch_closed then rec.ch:close() end
          end
          if rec then rt._gone(rec) end
        end
      end)
      ch:on_close(function(reason)
        if rt.daemons[host] == d then rt.daemons[host] = nil end
        rt._host_lost(host, sformat("host %s lost (daemon gone: %s)", host, tostring(reason)))
      end)
      -- heartbeat: a daemon that does not answer a ping within `hb_timeout` seconds is lost (a stopped or
      -- wedged daemon keeps its socket open: only the silence tells)
      local hb, hb_timeout = rt.heartbeat()
      local beat
      beat = core.every(hb, function()
        if rt.closing or d.ch ~= ch then beat:cancel() return end
        ch:request({ type = "ping" }, hb_timeout, function(r, perr)
          if not r and d.ch == ch and not rt.closing then
            beat:cancel()
            rt.daemons[host] = nil
            rt._host_lost(host, sformat("host %s lost (its daemon did not answer for %gs: %s)", host, hb_timeout,
              tostring(perr)))
            ch:close()
          end
        end)
      end)
      for _, w in ipairs(waiters) do w(ch) end
    end)
  end

  --- Starts `child` (a spec child) inactive on its host; cb(handle) | cb(nil, reason). A leaf's
  --- `config("key")` arguments are read first from the configuration replica of its host's daemon (and
  --- checked against the parameter's type): a missing key or a wrong type fails the start, naming the
  --- parameter and the key.
  function rt.spawn(child, cb)
    daemon(child.host, function(dch, err)
      if not dch then cb(nil, err) return end
      if child.kind == "leaf" and not child.resolved and config.has_params(child.args) then
        config.resolve_controller_params(child.args, config.over_channel(dch, timeouts.lookup), function(args, rerr)
          if not args then cb(nil, rerr) return end
          rt.spawn(setmetatable({ args = args, resolved = true }, { __index = child }), cb)
        end, { params = child.params })
        return
      end
      local addr = opts.hosts[child.host]
      local argv
      if child.kind == "leaf" then
        argv = { "dca", "node", "--type", child.type, "--name", child.path, "--daemon", addr }
        if opts.key then argv[#argv + 1] = "--key" argv[#argv + 1] = opts.key end
        argv[#argv + 1] = "--"
        for _, a in ipairs(child.args or {}) do argv[#argv + 1] = argstr(a) end
      else
        argv = { "dca", "supervise", "--name", child.path, "--daemon", addr }
        if opts.key then argv[#argv + 1] = "--key" argv[#argv + 1] = opts.key end
      end
      dch:request({ type = "spawn", argv = argv, name = child.path }, timeouts.spawn, function(r, rerr)
        if not r or r.type == "error" then cb(nil, r and r.reason or rerr) return end
        local rec = { name = child.name, host = child.host, child = r.child, pid = r.pid, path = child.path }
        rt.by_child[child.host .. ":" .. tostring(r.child)] = rec  -- child ids are per daemon
        local function kill(sig)
          if rec.exited then return end
          dch:request({ type = "kill", child = r.child, signal = sig or "TERM" }, 5, function(_, kerr)
            if kerr and not rec.exited and not rt.closing and rt.opts.log then
              rt.opts.log(sformat("kill %s: %s", child.path, tostring(kerr)))
            end
          end)
        end
        -- kill, then wait for the exit event (bounded): SIGKILL after `stop_grace` seconds, give up after as
        -- many again. cb(true) once gone | cb(false, reason)
        local function kill_wait(sig, cb)
          if cb then
            if rec.exited then cb(true) return end
            rec.on_exit = rec.on_exit or {}
            rec.on_exit[#rec.on_exit + 1] = cb
          end
          if rec.exited or rec.kill_timer then return end
          kill(sig)
          local grace = opts.stop_grace or 5
          rec.kill_timer = core.after(grace, function()
            if rec.exited then return end
            kill("KILL")
            rec.kill_timer = core.after(grace, function()
              rec.kill_timer = nil
              if rec.exited then return end
              local waiters = rec.on_exit
              rec.on_exit = nil
              for _, w in ipairs(waiters or {}) do
                w(false, sformat("%s (pid %s on host %s) did not exit within %gs of SIGKILL", child.path,
                  tostring(rec.pid), child.host, grace))
              end
            end)
          end)
        end
        dch:request({ type = "lookup", name = child.path, wait_ms = math.floor(timeouts.lookup * 1000) },
          timeouts.lookup + 1, function(lr, lerr)
            if not lr or lr.type == "error" then kill_wait("KILL") cb(nil, lr and lr.reason or lerr) return end
            local ep = lr.endpoints or lr
            local control = ep.control
            if not control then kill_wait("KILL") cb(nil, child.path .. " registered no control endpoint") return end
            core.connect(control, M.key_opts(opts.key), function(ch, cerr)
              if not ch then kill_wait("KILL") cb(nil, sformat("%s at %s: %s", child.path, control, tostring(cerr))) return end
              rec.ch = ch
              ch:on_message(function(msg, id)
                if (id or 0) == 0 and sup then sup:child_message(child.name, msg) end
              end)
              ch:on_close(function(reason)
                rec.ch_closed = true
                if rt.closing or rec.exited or rec.stopping or not sup then return end
                -- the process's exit event (with its signal) follows from its daemon (or the daemon's loss
                -- does, or its heartbeat): this bound only covers a process that closed its channel and lives on
                rec.lost_timer = core.after(opts.exit_grace or 10, function()
                  if rec.exited or rt.closing then return end
                  rec.exited = true
                  sup:child_exit(child.name, sformat("%s lost on host %s: %s", child.kind == "group" and "supervisor"
                    or "node", child.host, tostring(reason)))
                end)
              end)
              local h = {}
              function h.request(msg, timeout, rcb) ch:request(msg, timeout, rcb) end
              function h.send(msg) ch:send(msg) end
              --- Sends `sig` (via the daemon); cb(true) once the process has exited, cb(false, reason) when
              --- it outlives SIGKILL (bounded).
              function h.kill(sig, kcb)
                rec.stopping = true
                if rec.lost_timer then rec.lost_timer:cancel() end
                kill_wait(sig, kcb)
                ch:close()
              end
              --- Marks the process as gone for its owner (heartbeat lost): no further exit reports.
              function h.lost()
                rec.exited = true
                if rec.lost_timer then rec.lost_timer:cancel() end
              end
              h.pid, h.host = rec.pid, child.host
              cb(h)
            end)
          end)
      end)
    end)
  end

  --- Kills (SIGKILL) every process the lost child supervisor of `group` had started: the daemons of its
  --- subtree's hosts are asked which of their children bear a path below it. Best effort, nothing awaited.
  function rt.reap(group)
    local prefix = group.path .. "."
    local seen = {}
    local function visit(spec)
      for _, c in ipairs(spec.children or {}) do
        if c.host and not seen[c.host] then seen[c.host] = true end
        if c.kind == "group" and c.spec then visit(c.spec) end
      end
    end
    visit(group.spec or group)
    for host in pairs(seen) do
      daemon(host, function(dch)
        if not dch then return end
        dch:request({ type = "status" }, 5, function(r)
          for _, c in ipairs(r and r.children or {}) do
            if type(c.name) == "string" and c.name:sub(1, #prefix) == prefix then
              dch:request({ type = "kill", child = c.child, signal = "KILL" }, 5, function() end)
            end
          end
        end)
      end)
    end
  end

  -- This supervisor's host: opts.daemon_host, else the first host name.
  local function own_host()
    if opts.daemon_host then return opts.daemon_host end
    local names = {}
    for h in pairs(opts.hosts or {}) do names[#names + 1] = h end
    table.sort(names)
    return names[1]
  end

  --- The configuration repository of this supervisor's host (opts.daemon_host, else the first host): a
  --- dca.config client over that daemon's channel, its watch events delivered. cb(client) | cb(nil, err)
  function rt.config_client(cb)
    local host = own_host()
    daemon(host, function(dch, derr)
      if not dch then cb(nil, derr) return end
      local d = rt.daemons[host]
      if not d.config then d.config = config.over_channel(dch) d.config.host = host end
      cb(d.config)
    end)
  end

  --- A request to the robot process registered as `world` (dca sim --serve, or a robot's driver), looked up
  --- at the daemon of this supervisor's host (opts.daemon_host, else the first host; lookups reach the
  --- peers) and reached on its control channel (opened once). cb(reply) | cb(nil, err, missing)
  function rt.world(msg, timeout, cb)
    local w = rt._world
    if w and w.ch then w.ch:request(msg, timeout, cb) return end
    local function go(ch, err, missing)
      if ch then ch:request(msg, timeout, cb) else cb(nil, err, missing) end
    end
    if w then w.waiters[#w.waiters + 1] = go return end
    w = { waiters = { go } }
    rt._world = w
    local function finish(ch, err, missing)
      local ws = w.waiters
      w.waiters = {}
      if ch then w.ch = ch else rt._world = nil end
      for _, f in ipairs(ws) do f(ch, err, missing) end
    end
    local host = own_host()
    daemon(host, function(dch, derr)
      if not dch then finish(nil, derr) return end
      local wait_ms = math.floor((opts.world_wait or 5) * 1000)
      dch:request({ type = "lookup", name = opts.world_name or "world", wait_ms = wait_ms }, wait_ms / 1000 + 2,
        function(lr, lerr)
          local ep = lr and lr.type ~= "error" and (lr.endpoints or lr)
          if not ep or not ep.control then
            finish(nil, sformat("no process is registered as `%s` (asked the daemon of host %s: %s)",
              opts.world_name or "world", host, tostring(lr and lr.reason or lerr)), true)
            return
          end
          core.connect(ep.control, M.key_opts(opts.key), function(ch, cerr)
            if not ch then finish(nil, sformat("world at %s: %s", ep.control, tostring(cerr))) return end
            ch:on_message(function() end)
            ch:on_close(function() if rt._world == w then rt._world = nil end end)
            finish(ch)
          end)
        end)
    end)
  end

  --- Closes every daemon channel (after shutdown).
  function rt.close()
    rt.closing = true
    for _, d in pairs(rt.daemons) do if d.ch then d.ch:close() end end
    if rt._world and rt._world.ch then rt._world.ch:close() end
  end

  return rt
end

return M
