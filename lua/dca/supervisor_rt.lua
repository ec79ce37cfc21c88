-- dca.supervisor_rt: the real runtime of a supervisor, over `dca.core` channels and the hosts' daemons.
--
-- argv[1] is "dca": the daemon starts its own executable (its allow-list admits `dca node|supervise|sim`).
-- Leaves start as `dca node --type T --name PATH --daemon ADDR -- ARGS` and sub-groups as
-- `dca supervise --name PATH --daemon ADDR`, each by the daemon (Executer) of its host; the supervisor then
-- looks the new process up by its path (NameServer) and opens a channel to its `control` endpoint.
-- Exit events from a daemon and closed channels become child_exit(name, reason) on the owning supervisor.
--
--   local rt = require("dca.supervisor_rt").new{ hosts = { h1 = "127.0.0.1:7001" }, key = FILE, exe = DCA,
--                                                report = function(msg) end, log = function(line) end }
--   rt.bind(sup)           -- the supervisor whose children this runtime starts (after supervisor.new)
--   rt.reply(ch, req, msg) -- answers a request that arrived on a channel
local core = require "dca.core"

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
  function rt.report(msg) if opts.report then opts.report(msg) end end
  function rt.log(line) if opts.log then opts.log(line) end end

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
        if msg.type == "exit" then
          local rec = rt.by_child[host .. ":" .. tostring(msg.child)]
          if rec and sup and not rec.exited then
            rec.exited = true
            if rec.lost_timer then rec.lost_timer:cancel() end
            sup:child_exit(rec.name, M.describe_exit(msg, host))
            if rec.ch and not rec.ch_closed then rec.ch:close() end
          end
        end
      end)
      ch:on_close(function(reason)
        rt.daemons[host] = nil
        if rt.closing or not sup then return end
        for _, rec in pairs(rt.by_child) do
          if rec.host == host and not rec.exited then
            rec.exited = true
            sup:child_exit(rec.name, sformat("host %s lost (daemon gone: %s)", host, tostring(reason)))
          end
        end
      end)
      -- heartbeat: a daemon that does not answer a ping within `heartbeat` seconds is lost
      local hb = opts.heartbeat or 1
      local beat
      beat = core.every(hb, function()
        if rt.closing or d.ch ~= ch then beat:cancel() return end
        ch:request({ type = "ping" }, 2 * hb, function(r, perr)
          if not r and d.ch == ch and not rt.closing then
            beat:cancel()
            ch:close()
            if sup then
              for _, rec in pairs(rt.by_child) do
                if rec.host == host and not rec.exited then
                  rec.exited = true
                  sup:child_exit(rec.name, sformat("host %s lost (no heartbeat for %gs: %s)", host, 2 * hb, tostring(perr)))
                end
              end
            end
          end
        end)
      end)
      for _, w in ipairs(waiters) do w(ch) end
    end)
  end

  --- Starts `child` (a spec child) inactive on its host; cb(handle) | cb(nil, reason).
  function rt.spawn(child, cb)
    daemon(child.host, function(dch, err)
      if not dch then cb(nil, err) return end
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
            if kerr and not rt.closing and rt.opts.log then rt.opts.log(sformat("kill %s: %s", child.path, tostring(kerr))) end
          end)
        end
        dch:request({ type = "lookup", name = child.path, wait_ms = math.floor(timeouts.lookup * 1000) },
          timeouts.lookup + 1, function(lr, lerr)
            if not lr or lr.type == "error" then kill("KILL") cb(nil, lr and lr.reason or lerr) return end
            local ep = lr.endpoints or lr
            local control = ep.control
            if not control then kill("KILL") cb(nil, child.path .. " registered no control endpoint") return end
            core.connect(control, M.key_opts(opts.key), function(ch, cerr)
              if not ch then kill("KILL") cb(nil, sformat("%s at %s: %s", child.path, control, tostring(cerr))) return end
              rec.ch = ch
              ch:on_message(function(msg, id)
                if (id or 0) == 0 and sup then sup:child_message(child.name, msg) end
              end)
              ch:on_close(function(reason)
                rec.ch_closed = true
                if rt.closing or rec.exited or rec.stopping or not sup then return end
                -- the process's exit event (with its signal) usually follows at once: give it a moment
                rec.lost_timer = core.after(opts.exit_grace or 0.5, function()
                  if rec.exited or rt.closing then return end
                  rec.exited = true
                  sup:child_exit(child.name, sformat("%s lost on host %s: %s", child.kind == "group" and "supervisor"
                    or "node", child.host, tostring(reason)))
                end)
              end)
              local h = {}
              function h.request(msg, timeout, rcb) ch:request(msg, timeout, rcb) end
              function h.send(msg) ch:send(msg) end
              function h.kill(sig)
                rec.stopping = true
                kill(sig)
                ch:close()
              end
              cb(h)
            end)
          end)
      end)
    end)
  end

  --- Closes every daemon channel (after shutdown).
  function rt.close()
    rt.closing = true
    for _, d in pairs(rt.daemons) do if d.ch then d.ch:close() end end
  end

  return rt
end

return M
