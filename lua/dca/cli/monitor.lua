-- `dca monitor ADDR|PATH|FILE.mcap`: the web monitor of a running system (attached to its root supervisor's
-- console, over the authenticated control plane, like `dca repl`), or the replay of a recorded run.
local core = require "dca.core"
local args_mod = require "dca.cli.args"

local M = {}

local tostring = tostring

M.summary = "the web monitor of a running system (ADDR, PATH) or of a recording (FILE.mcap)"
M.usage = [[usage: dca monitor ADDR|PATH [--daemon ADDR] [--key FILE] [--listen ADDR]
       dca monitor FILE.mcap [--system FILE.dca] [--root NAME] [--listen ADDR]
       dca monitor --token [--key FILE]

Serves the monitor's page on --listen (default 127.0.0.1:0, a free port) and prints its address with its
token; without the token the page shows nothing and changes nothing.
  ADDR|PATH     a running system: the console address of its root supervisor (what `dca run` prints as
                "console: dca repl main --daemon ADDR --key FILE"), or its path looked up at --daemon. The
                monitor is a console like `dca repl`: it authenticates with the cluster key (--key FILE,
                else $DCA_KEY_FILE, else the user's), follows the root's lines and asks for the tree; the
                page's commands (abort, restart, config set) are console commands; with --daemon (the
                daemon of the root's host), the ports are plotted (each tapped, as the root's console
                request `tap`, into a tap point of this process registered there) and the world's
                signals of a run in simulated time
  FILE.mcap     a run recorded by `dca run --sim WORLD --record FILE.mcap`: its lines (/dca/events) and
                signals, with a time slider and play/pause; --system FILE.dca adds the hosts, types and
                expressions of the system that ran
  --token       print the token of the cluster key (--key FILE, else $DCA_KEY_FILE, else the user's): the
                monitor of `dca run --monitor` on a system with that key admits it as it admits the token it
                printed, so a key holder opens http://ADDR/?token=THAT without the run's output]]

local OPTIONS = { ["--daemon"] = "value", ["--key"] = "value", ["--listen"] = "value", ["--system"] = "value",
                  ["--root"] = "value", ["--token"] = "flag" }

-- Serves `mon` until Ctrl-C (or `stop_when()`), `live` (its port taps, if any) closed first. --> 0
local function serve(mon, what, live)
  io.stdout:write(what, "\n", "monitor: ", mon:url(), "\n")
  io.stdout:flush()
  local loop = core.loop()
  core.on_signal(function() loop:stop() end)
  loop:run()
  if live then live:close() end
  mon:close(loop)
  return 0
end

-- A recording, replayed.
local function replay(o)
  local spec
  if o.system then
    local serr
    -- (no world check: a replay wires no device port, and the recording's world may be any robot's)
    spec, serr = require("dca.load").spec(o.system, { root = o.root, world = false })
    if not spec then io.stderr:write(serr, "\n") return 2 end
  end
  local rec, err = require("dca.monitor.replay").load(o[1], spec)
  if not rec then io.stderr:write("dca monitor: ", tostring(err), "\n") return 1 end
  local mon, merr = require("dca.monitor.server").start{ addr = o.listen, name = tostring(rec.root or o[1]),
    root = rec.root, mode = "replay", model = rec.model, series = rec.series, robot = rec.robot }
  if not mon then io.stderr:write("dca monitor: ", tostring(merr), "\n") return 1 end
  if spec then  -- the ports' units, from their manifests (the plot's legend), as live
    local units = {}
    for _, p in ipairs(require("dca.supervisor.taps").outputs(spec, core.types())) do
      if p.units ~= "" then units[require("dca.launch.live").topic_of(p.path)] = p.units end
    end
    mon.topic_units = function(name) return units[name] end
  end
  return serve(mon, string.format("replaying %s: %d events, %d signals", o[1], #rec.model.events, #rec.series))
end

-- The world's status requests (the page's world signals), to the `world` registered at `daemon` (a run in
-- simulated time): looked up once, on the first request; no world, no signals.
local function world_at(daemon, key)
  local clients = require "dca.clients"
  local wc, asked
  return function(msg, cb)
    if wc then wc:request(msg, 2, cb) return end
    if asked then cb(nil) return end
    asked = true
    require("dca.clients.daemon").connect(daemon, { key_file = key }, function(d)
      if not d then return end
      clients.open(d, "world", 0, { key_file = key }, clients.Plain, function(c) wc = c end)
    end)
    cb(nil)
  end
end

-- A running system, through its root's console.
local function attach(o)
  local console = require "dca.clients.console"
  local loop = core.loop()
  local function await(fn)
    local res
    fn(function(...) res = table.pack(...) end)
    loop:run_until(function() return res ~= nil end, 20)
    if not res then return nil, "no answer within 20 s" end
    return table.unpack(res, 1, res.n)
  end
  local addr, target = o[1], o[1]
  if not target:match(":%d+$") and not target:match("^/") and not target:match("^unix:") then
    if not o.daemon then io.stderr:write("dca monitor: to find '", target, "' give --daemon ADDR\n") return 2 end
    local ferr
    addr, ferr = await(function(k) console.find(o.daemon, target, { key_file = o.key }, k) end)
    if not addr then io.stderr:write("dca monitor: ", tostring(ferr), "\n") return 1 end
  end
  local client, cerr = await(function(k) console.connect(addr, { key_file = o.key }, k) end)
  if not client then io.stderr:write("dca monitor: ", addr, ": ", tostring(cerr), "\n") return 1 end
  local function request(msg, cb)
    client:request(msg, console.EVAL_TIMEOUT, function(r, err) cb(r or { type = "error", reason = tostring(err) }) end)
  end
  local ping = await(function(k) request({ type = "ping" }, k) end) or {}
  local mon, merr = require("dca.monitor.server").start{ addr = o.listen, name = tostring(ping.path or target),
    root = ping.path, mode = "live", request = request, world = o.daemon and world_at(o.daemon, o.key) }
  if not mon then io.stderr:write("dca monitor: ", tostring(merr), "\n") return 1 end
  client:follow(function(line) mon:line(line) end)
  local live
  live = o.daemon and require("dca.launch.live").attach({ daemon = o.daemon, key = o.key, root = ping.path },
    mon.srv, request, function(ok, lerr)
      if not ok then io.stderr:write("dca monitor: ", tostring(lerr), " (no port plots)\n") return end
      mon.on_subscribe = function(id) live:tap_id(id) end
      mon.topic_units = function(name) return live:units(name) end
    end)
  client:on_close(function(reason)
    io.stderr:write("dca monitor: the supervisor's console closed: ", tostring(reason), "\n")
    loop:stop()
  end)
  return serve(mon, "attached to " .. tostring(ping.path) .. " at " .. addr, live)
end

function M.main(args)
  local o, err = args_mod.parse(args, "dca monitor", OPTIONS)
  if not o then return args_mod.usage_error(err, M.usage) end
  if o.token then
    local token, terr = core.monitor_token(o.key)
    if not token then io.stderr:write("dca monitor: ", tostring(terr), "\n") return 1 end
    io.stdout:write(token, "\n")
    return 0
  end
  if not o[1] then return args_mod.usage_error("dca monitor: which system (ADDR, PATH) or recording (FILE.mcap)?", M.usage) end
  if o[1]:match("%.mcap$") then return replay(o) end
  if o.system then return args_mod.usage_error("dca monitor: --system goes with FILE.mcap", M.usage) end
  return attach(o)
end

return M
