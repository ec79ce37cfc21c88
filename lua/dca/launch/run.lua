-- dca.launch.run: one run of a system, what `dca run` does without its argv and its terminal: the start
-- (dca.launch.start), the progress lines (stamped with the world's time in simulated time), the consoles that
-- follow the root, reloads (--watch too), the start's deadline, the end with the world's summary, Ctrl-C.
--
--   local code = require("dca.launch.run").main(spec, o, out)   -- o: the options of `dca run` (cli/run.lua)
--   out = { line = fn(text),      -- a line for the person (progress, the summary)
--           outcome = fn(text),   -- the root's ABORTED line
--           error = fn(text),     -- what went wrong (the cli names itself before it)
--           console = fn(exe, address, key) --> pid | nil }   -- with o.repl: a console process on the terminal
-- The exit code: 0 when the root ends DONE, 1 ABORTED, 2 usage or configuration errors, 3 a failed start,
-- 130 after Ctrl-C. After 1 or 3 the local daemons' logs are kept, and their folder named.
local core, clients = require "dca.core", require "dca.clients"
local supervisor, srt = require "dca.supervisor", require "dca.supervisor.net"
local hosts_mod, start = require "dca.launch.hosts", require "dca.launch.start"

local M = {}

local ipairs, tostring, sformat = ipairs, tostring, string.format

-- A run: its options, spec, start context (dca.launch.start), the consoles following its lines, its exit code.
local Run = {}
Run.__index = Run

-- An error line through the hook (the cli prefixes it with its name).
local function err_line(self, ...)
  local parts = table.pack(...)
  for i = 1, parts.n do parts[i] = tostring(parts[i]) end
  self.out.error(table.concat(parts, "", 1, parts.n))
end

-- Writes a line for the person: to the consoles following the root (with --repl they own the terminal and
-- print it above their prompt), else to stdout.
function Run:emit(text)
  if srt.to_followers(self.followers, text) > 0 and self.o.repl then return end
  self.out.line(text)
end

-- A progress line, stamped with the world's time (with --sim, in order) or the wall time since the start;
-- `output`: the path of the process that wrote it to its stderr (dca.supervisor: Sup:output).
--- `private`: a line that carries the monitor's token, said on the terminal only: never to the monitor's
--- viewers, the recording (a replay would show it to whoever has the file) or the trace.
function Run:say(line, at, output, private)
  -- the trace keeps the lines that carry their event's simulated time (dca.trace)
  if self.o.trace_file and at then self.trace_lines[#self.trace_lines + 1] = { math.floor(at * 1e9 + 0.5), line } end
  local s, mon, live = self.ctx.sim, self.monitor, self.live
  if private then mon, live = nil, nil end
  if s and s.world:connected() then
    s:stamp(line, function(t, l)
      if mon then mon:line(l, t) end
      if live then live:line(l, t, output) end
      if not self.o.quiet then self:emit(sformat("[sim %8.3f] %s", t, l)) end
    end, at, output, private)
  else
    if mon then mon:line(line, core.now() - self.t0) end
    if live then live:line(line, nil, output) end
    if self.wall_rec and not private then self.wall_rec:line(line, output) end
    if not self.o.quiet then self:emit(sformat("[%7.3f] %s", core.now() - self.t0, line)) end
  end
end

-- The root's outcome line to stderr (or the consoles), in order with the stamped lines.
function Run:say_aborted(msg)
  local text = sformat("%s: ABORTED at %s: %s", self.spec.path, tostring(msg.path), tostring(msg.reason))
  local function out(t)
    if not (self.o.repl and srt.to_followers(self.followers, t) > 0) then self.out.outcome(t) end
  end
  local s, mon = self.ctx.sim, self.monitor
  -- (the monitor takes the root's outcome as its last event: the pages show the root aborted before they close)
  if s and s.world:connected() then
    s:stamp(text, function(t)
      if mon then mon:line(text, t) end
      if self.live then self.live:line(text, t) end
      out(sformat("[sim %8.3f] %s", t, text))
    end)
  else
    if mon then mon:line(text, core.now() - self.t0) end
    if self.live then self.live:line(text) end
    if self.wall_rec then self.wall_rec:line(text) end
    out(text)
  end
end

-- What the root reports: its lines and its outcome (which ends the run unless a console holds it).
function Run:report(msg)
  -- the trace ends at the root's outcome: what follows (the shutdown) is no part of the run
  if (msg.type == "done" or msg.type == "aborted") and tonumber(msg.now) then
    self.trace_end = tonumber(msg.now)
    if self.live and self.ctx.sim then self.live:ended(self.trace_end / 1e9) end
    self:hold_at_the_end()
  end
  if msg.type == "restarted" then self:retap(msg.path) return end
  if msg.type == "log" then self:say(msg.line, msg.at, msg.output)
  elseif msg.type == "done" then
    self:say(sformat("%s: DONE %s", self.spec.path, supervisor.show(msg.value)), tonumber(msg.now) and msg.now / 1e9)
    if not self.o.repl then self.code = self.code or 0 self:wind_up() end
  elseif msg.type == "aborted" then
    self:say_aborted(msg)
    if not self.o.repl then self.code = self.code or 1 self:wind_up() end
  end
end

-- In simulated time the run ends at the root's outcome: time holds there while the tree stops (a console that
-- holds the run on, --repl, keeps it flowing). The root's supervisor is on the world's clock, so the world waits
-- for its answer of this tick while this hold, sent first, comes in: the recording ends at the outcome's tick,
-- the same in every run, instead of with however many ticks the shutdown took in wall time.
function Run:hold_at_the_end()
  local s = self.ctx.sim
  if self.o.repl or not (s and s.world:connected()) then return end
  s.world:request({ type = "hold" }, 10, function() end)
end

-- With --blackbox: once the tree is down, the world alone (its writers gone: its safe values) runs on for the
-- black box's AFTER seconds past the end, then holds, so a fault at the end gets its whole window, the same in
-- every run. k() after (or at once).
function Run:after_the_end(k)
  local s, after = self.ctx.sim, tonumber(tostring(self.o.blackbox or ""):match("^[^,]+,([^,]+)"))
  if not (after and after > 0 and self.trace_end and s and s.world:connected()) or self.o.repl then k() return end
  local at = self.trace_end + math.floor(after * 1e9 + 0.5)
  local deadline, done = core.now() + 60, false
  local function finish()
    if done then return end
    done = true
    k()
  end
  local function poll()
    s.world:request({ type = "status" }, 10, function(r)
      if not r or (not r.running and r.settled) or core.now() > deadline then finish() return end
      core.after(0.02, poll)
    end)
  end
  s.world:request({ type = "hold", at = at }, 10, function(r)
    if not r then finish() return end
    s.world:request({ type = "go" }, 10, function(g) if g then poll() else finish() end end)
  end)
end

-- The tree, then the recording closed and the world stopped, then the loop. On the wall clock with --record:
-- the real-time figures once more before the tree stops, the recording closed after the driver.
function Run:down()
  local s = self.ctx.sim
  local function shutdown()
    self.sup:shutdown(function()
      if not s then
        require("dca.launch.driver").stop(self.ctx, function() self:end_wall_recording() self.loop:stop() end)
        return
      end
      self:live_summary()
      self:after_the_end(function()
        self:end_recording(function() s.world:stop(function() self:write_trace() self.loop:stop() end) end)
      end)
    end)
  end
  local rec = self.wall_rec
  if not (rec and not rec.finished and not self.last_polled) then shutdown() return end
  self.last_polled = true
  rec:poll(shutdown)
end

-- With --record FILE.mcap on the wall clock (dca.launch.wall_record): the recording closed and what it holds
-- said, as a world says it ("recorded FILE: N messages on K channels (...), C chunks").
function Run:end_wall_recording()
  local rec = self.wall_rec
  if not rec or rec.finished then return end
  local summary, err = rec:finish()
  if summary then self:emit("recorded " .. summary) else err_line(self, "--record: ", tostring(err)) end
end

-- A console request of the root's own (srt.console: the requests and checks of `dca repl`), answered to cb(reply).
function Run:console_request(msg, cb)
  local ch = { reply = function(_, _, p) p.type = p.type or "ok" cb(p) return true end,
               reply_error = function(_, _, reason) cb({ type = "error", reason = reason }) return true end }
  srt.console(ch, 1, msg, self.sup, {})
end

-- With --monitor: what the live taps took in and dropped (a busy root drops the oldest, counted).
function Run:live_summary()
  if not self.live then return end
  local n, taken, dropped = 0, 0, 0
  for _, st in pairs(self.live:stats()) do
    n, taken, dropped = n + 1, taken + (st.taken or 0), dropped + (st.dropped or 0)
  end
  if n > 0 then self:emit(sformat("live taps: %d ports, %d samples taken, %d dropped", n, taken, dropped)) end
end

-- With --record FILE.mcap: the world closes the recording and says what it holds ("recorded FILE: N messages
-- on K channels (/world/arm/q n, ..., /main/door/hit/Out n), C chunks"). k() after.
function Run:end_recording(k)
  local s, file = self.ctx.sim, self.o.record
  if not (file and file:match("%.mcap$") and s.world:connected()) then k() return end
  s.world:request({ type = "record_end" }, 10, function(r, err)
    if r and r.summary then self:emit("recorded " .. tostring(r.summary))
    elseif not r then err_line(self, "--record: ", tostring(err)) end
    k()
  end)
end

-- With --record-ports: each output named linked to the world (a tap, host/tap.h), which records its samples at
-- their ticks on a channel of their own. cb(true) | cb(nil, err)
function Run:record_ports(cb)
  local o, s = self.o, self.ctx.sim
  if not (o.record_ports and s) then cb(true) return end
  local taps = require "dca.supervisor.taps"
  local list, err = taps.select(self.spec, self.ctx.rt.types and self.ctx.rt.types() or {}, o.record_ports)
  if not list then cb(nil, err) return end
  taps.connect(self.sup, list, "world", { prepare = function(p, k)
    s.world:request({ type = "tap", path = p.path, port_type = p.type, size = p.size, units = p.units,
                      message = p.message }, 10,
      function(r, werr) k(r ~= nil, werr) end)
  end }, function(ok, terr)
    if ok then self:say(sformat("recording %d ports to %s", #list, tostring(o.record))) self.recorded = list end
    cb(ok, terr)
  end)
end

-- With --trace: the world's trace and the transition lines merged into the file (dca.trace).
function Run:write_trace()
  local o = self.o
  if not o.trace_file then return end
  local ok, err = require("dca.trace").merge(o.trace, self.trace_lines, o.trace_file, self.trace_end)
  core.remove_tree(o.trace)
  if ok then self:emit("trace: " .. o.trace_file) else err_line(self, "--trace: ", tostring(err)) end
end

-- The end of a run: the world's summary (with --sim), then down.
function Run:wind_up()
  local s = self.ctx.sim
  if not s then self:down() return end
  local function summary()
    s:summary(core.now() - self.t0, function(lines)
      for _, l in ipairs(lines) do self:emit(l) end
      self:down()
    end)
  end
  if not self.o.trace_file then summary() return end
  -- with --trace: time held once the outcome's tick has ended (its barrier done, its lines written), within 10 s
  local deadline = core.now() + 10
  s.world:hold(function()
    local function check()
      s.world:request({ type = "status" }, 10, function(r)
        if (r and not r.running and r.settled) or core.now() > deadline then summary() else core.after(0.005, check) end
      end)
    end
    check()
  end)
end

-- Stops everything with exit code `c` (unless one is set), bounded: the daemons are killed after the loop.
function Run:stop_all(c)
  if self.code == nil then self.code = c end
  self.stopping = true  -- a start still in flight goes no further (start_world)
  self:down()
  core.after(15, function() self.loop:stop() end)
end

-- The root listens for consoles (`dca repl main`) and registers its path with its host's daemon.
function Run:listen()
  local key, hosts, spec = self.ctx.key, self.ctx.hosts, self.spec
  self.listener = core.listen("127.0.0.1:0", clients.key_opts(key), function(ch)
    ch:on_message(function(msg, id) srt.console(ch, id, msg, self.sup, self.followers) end)
    ch:on_close(function() self.followers[ch] = nil end)
  end)
  local root_daemon = hosts[spec.host]
  if not (self.listener and root_daemon) then return end
  require("dca.clients.daemon").connect(root_daemon, clients.key_opts(key), function(d)
    if not d then return end
    self.ctx.rt.root_daemon = d   -- read by nothing: it keeps the registration open; start.cleanup closes it
    d:register(spec.path, { control = self.listener:address() })
    self:say(sformat("console: dca repl %s --daemon %s --key %s", spec.path, root_daemon, tostring(key)))
  end)
end

-- --monitor: the web monitor on the root's loop (dca.monitor.server). Its commands are console requests,
-- answered as the root's console answers `dca repl` (srt.console: the same requests, the same checks). --> ok | nil, err
function Run:start_monitor()
  local function request(msg, cb) self:console_request(msg, cb) end
  -- the world (with --sim) once it is started
  local world = self.o.sim and function(msg, cb)
    local s = self.ctx.sim
    if s and s.world:connected() then s.world:request(msg, 2, cb) else cb(nil) end
  end
  local mon, err = require("dca.monitor.server").start{
    addr = self.o.monitor ~= true and self.o.monitor or nil, name = self.spec.path, root = self.spec.path,
    mode = "live",
    request = request, world = world, world_spec = self.o.sim,
    blackbox = self.o.blackbox and function(why, cb) self:blackbox(why, cb) end or nil }
  if not mon then return nil, err end
  mon.srv:add_key_token(self.ctx.key)  -- a key holder's token too (`dca monitor --token --key FILE`)
  self.monitor = mon
  self:say("monitor: " .. mon:url(), nil, nil, true)
  return true
end

-- A leaf restarted (a fresh process), or every leaf below a group: its taps made again (the recording's, the
-- live ones), since its new process has none of its old links.
function Run:retap(path)
  path = tostring(path)
  local function below(p) return p.leaf == path or p.leaf:sub(1, #path + 1) == path .. "." end
  local list = {}
  for _, p in ipairs(self.recorded or {}) do if below(p) then list[#list + 1] = p end end
  if #list > 0 then
    require("dca.supervisor.taps").connect(self.sup, list, "world", {}, function(ok, err)
      if not ok then err_line(self, "--record-ports: after the restart of ", path, ": ", tostring(err)) end
    end)
  end
  if self.live then self.live:retap(below) end
end

-- With --monitor: the run's live samples (dca.launch.live) on the monitor's server: every port (and world
-- signal) a topic, tapped when a viewer subscribes (the page, or Foxglove on the same server). cb() after; a
-- failure is said and the run goes on without them.
function Run:start_live(cb)
  local mon = self.monitor
  if not mon then cb() return end
  self.live = require("dca.launch.live").start(self.ctx, self.sup, mon.srv, function(ok, err)
    if not ok then err_line(self, "live taps: ", tostring(err)) cb() return end
    mon.on_subscribe = function(id) self.live:tap_id(id) end
    mon.topic_units = function(name) return self.live:units(name) end  -- (the plot's units: the manifests')
    if self.live.robot then mon:robot{ urdf = self.live.robot.urdf, frames = self.live.robot.frames, topic = self.live.robot.id } end
    self:say(sformat("foxglove: ws://%s/?token=%s (Foxglove, Lichtblick: foxglove.websocket.v1)", mon.srv:address(),
      mon.srv:token()), nil, nil, true)
    cb()
  end)
end

-- reload: the file again (validated first; on an error the old version keeps running), or the modules.
function Run:reload(what, cb)
  local reload = require "dca.reload"
  if what == "modules" then cb(reload.modules()) return end
  local world = self.o.sim or (self.o.driver and self.o.driver.signals)  -- (a driver's: dca.launch.driver)
  reload.system(self.sup, what or self.o.file, { root = self.o.root, world = world }, function(lines, err)
    if not lines then lines = { "reload refused, the running version is kept:", err }
    elseif #lines == 0 then lines = { "no change" } end
    cb(lines)
  end)
end

-- --watch: the file reloaded when it is saved.
function Run:watch()
  local w, werr = core.watch_file(self.o.file)
  if not w then err_line(self, "--watch: ", werr) return end
  core.every(0.2, function()
    if w:changed() then
      self:reload(nil, function(lines) for _, l in ipairs(lines) do self:say("reload: " .. l) end end)
    end
  end)
end

-- --repl: a console on the root's console endpoint (the hook out.console starts it: `dca repl` on the terminal,
-- in its own process, so that line editing owns the terminal while this loop keeps the system running); its
-- exit ends the run.
function Run:open_console()
  local pid = self.out.console(self.ctx.exe, self.listener:address(), self.ctx.key)
  if not pid then err_line(self, "could not start the console") return end
  local watch
  watch = core.every(0.1, function()
    if hosts_mod.alive(pid) then return end
    watch:cancel()
    local st = self.sup.outcome and self.sup.outcome.status
    self:stop_all(st == "done" and 0 or (st == "aborted" and 1 or 130))
  end)
end

-- The root runs; simulated time starts once every process the start ran has its run (a repeatable start), and
-- with --monitor-wait once a monitor page is connected.
function Run:run_root()
  self:say(self.spec.path .. ": the whole tree is configured: run")
  if self.wall_rec then self.wall_rec:start_polling() end
  self.sup:run_expr(nil, function()
    local s = self.ctx.sim
    if not s then return end
    local function go()
      s.world:go(function(r, gerr)
        if not r then err_line(self, "the world did not start its time: ", tostring(gerr)) self:stop_all(3) end
      end)
    end
    if self.monitor and self.o.monitor_wait then
      -- a monitor page that connects or a Foxglove client that subscribes, whichever comes first
      self:say("monitor: time starts when a page is connected (or a Foxglove client subscribes)")
      local started = false
      local function first() if not started then started = true go() end end
      self.monitor:on_page(first)
      if self.live then self.live:on_client(first) end
    else
      go()
    end
  end)
  if self.o.repl and self.listener then self:open_console() end
end

-- The tree comes up (start, connect, confirm) within --timeout, then runs.
function Run:bring_up()
  local deadline = core.after(self.o.timeout, function()
    if self.sup.state == "starting" or self.sup.state == "new" then
      err_line(self, sformat("the start did not finish within %gs", self.o.timeout))
      self:stop_all(3)
    end
  end)
  self.sup:configure(function(ok, err)
    if not ok then err_line(self, "start failed: ", tostring(err)) self:stop_all(3) return end
    self:record_ports(function(tok, terr)
      if not tok then err_line(self, "--record-ports: ", tostring(terr)) self:stop_all(3) return end
      deadline:cancel()
      self:start_live(function() self:run_root() end)
    end)
  end)
end

-- The exit code when start step `step` failed (see dca.launch.start): usage and configuration errors 2.
local function start_code(o, step, kind)
  if kind == "signal" then return 130 end
  if step == "hosts" then return o.hosts and 2 or 3 end
  if step == "config" then return kind and 2 or 3 end
  if step == "sim_clock" then return 2 end
  return 3
end

-- With --sim: the daemons' clock checked (a hosts file) and the world started, then the tree comes up.
function Run:start_world()
  local ctx = self.ctx
  start.sequence(ctx, { "sim_clock", "world", "driver" }, function(ok, err, step, kind)
    local robot = ctx.sim and ctx.sim.world or ctx.driver  -- the world, or a robot's driver (--driver)
    if not ok then
      if self.stopping then return end  -- interrupted: the world's start was cut short on purpose
      err_line(self, tostring(err))
      self.code = start_code(self.o, step, kind)
      if robot then robot:stop(function() self.loop:stop() end) else self.loop:stop() end
      return
    end
    if robot then
      -- the world gone, nothing can run on: the root ends ABORTED with the cause and everything is stopped
      -- (bounded: stop_all's grace), instead of the run waiting for ever with its daemons and supervisors up
      robot.on_lost = function(reason)
        err_line(self, reason, ctx.sim and " (the nodes on its clock stop with it)" or "")
        if self.code == nil then self.code = 1 end
        if self.sup.state == "running" then
          self.sup:abort(function() self:stop_all(1) end, "the robot process was lost: " .. reason)
        else
          self:stop_all(1)
        end
      end
    end
    if self.stopping then return end
    if ctx.sim then ctx.sim.world:watch_estop(function(ev) self:estop_event(ev) end) end
    self:bring_up()
  end)
end

-- Hosts and configuration (dca.launch.start). --> true | nil, exit code
function Run:prepare()
  if not core.loop or not core.connect then
    err_line(self, "this dca has no control plane (dca.core.loop/connect)")
    return nil, 3
  end
  local done, code
  start.sequence(self.ctx, { "hosts", "config" }, function(ok, err, step, kind)
    done = true
    if ok then return end
    err_line(self, err)
    start.cleanup(self.ctx)
    code = start_code(self.o, step, kind)
  end)
  assert(done, "hosts and config do not wait")
  if code then return nil, code end
  return true
end

-- The black box's trigger on demand (SIGUSR2, docs/recording.md "Black box"): the world's `blackbox {why}`,
-- said with its tick; cb(reply {t} | nil, err) if given (the monitor's page).
function Run:blackbox(why, cb)
  local s = self.ctx.sim
  if not (s and s.world:connected()) then
    self:say("black box: no world to trigger it in yet (" .. why .. ")")
    if cb then cb(nil, "no world to trigger it in yet") end
    return
  end
  s.world:request({ type = "blackbox", why = why }, 10, function(r, err)
    if r and r.t then self:say(sformat("black box triggered (%s) at %.3f s", why, r.t))
    else self:say("black box: " .. why .. ": " .. tostring(err)) end
    if cb then cb(r and r.t and r or nil, err or (r and r.reason)) end
  end)
end

-- The emergency stop (docs/safety.md, "Emergency stop") pressed or released: req {type = "estop" | "release",
-- source} to the world (with --sim: it tells each change as an event, Run:estop_event), or to the driver
-- (--driver). cb(reply {t, already, source}) | cb(nil, err)
function Run:estop_request(req, cb)
  local s = self.ctx.sim
  if s and s.world:connected() then s.world:request(req, 10, cb) return end
  if not (self.o.sim or self.o.driver) then cb(nil, req.type .. ": this run has no robot (neither --sim nor --driver)") return end
  if not self.ctx.driver then cb(nil, req.type .. ": the robot is not up yet") return end
  require("dca.launch.driver").estop(self.ctx, req, core.now() - self.t0, function(r, x)
    if not r then cb(nil, x) return end
    if x then self:estop_event(x) end
    cb(r)
  end)
end

-- A press or release of the emergency stop: the root supervisor's event (it says the line, and tells the
-- groups below).
function Run:estop_event(ev)
  require("dca.supervisor.requests").estop_event(self.sup, ev, true)
end

--- Runs the system of `spec` with options `o`, talking through `out` (see the header). --> exit code
function M.main(spec, o, out)
  local r = setmetatable({ o = o, spec = spec, out = out, followers = {}, t0 = core.now(), trace_lines = {} }, Run)
  r.ctx = start.context(spec, o, { say = function(line) r:say(line) end, report = function(msg) r:report(msg) end,
                                   log = function(line, at) r:say(line, at) end })
  if o.record and not o.sim then
    -- on the wall clock (--driver, or no simulator) the run writes the recording itself
    local rec, rerr = require("dca.launch.wall_record").open(o.record, spec,
      function(msg, cb) r:console_request(msg, cb) end)
    if not rec then err_line(r, "--record: ", tostring(rerr)) return 2 end
    r.wall_rec = rec
  end
  local pok, code = r:prepare()
  if not pok then
    if r.wall_rec then r.wall_rec:finish() end
    return code
  end
  r.loop = core.loop()
  r.sup = start.tree(r.ctx, spec.host)
  local function interrupted(sig) r:say("interrupted (SIG" .. tostring(sig) .. "): stopping") r:stop_all(130) end
  core.on_signal(interrupted)
  if o.blackbox then core.on_usr2(function() r:blackbox("SIGUSR2") end) end
  core.on_usr1(function()
    r:estop_request({ type = "estop", source = "SIGUSR1" }, function(res, err)
      if not res then r:say("emergency stop (SIGUSR1): " .. tostring(err)) end
    end)
  end)
  r.sup.estop_hook = function(req, cb) r:estop_request(req, cb) end
  -- the simulated clock's commands (pause, step, speed: dca.supervisor.requests.clock) go to the run's world
  r.sup.clock_hook = function(req, cb)
    local s = r.ctx.sim
    if s and s.world:connected() then s.world:request(req, 10, cb) return end
    cb(nil, r.o.sim and "the world is not up yet" or "this run has no simulated clock (no --sim)")
  end
  -- one that came between the last start step and on_signal: held since main (bindings/stop_signals.h)
  if core.pending_signal() then core.after(0, function() interrupted(core.pending_signal()) end) end
  r:listen()
  if o.monitor then
    local mok, merr = r:start_monitor()
    if not mok then err_line(r, merr) start.cleanup(r.ctx) return 2 end
  end
  r.sup.reload_hook = function(what, cb) r:reload(what, cb) end
  if o.watch then r:watch() end
  r:start_world()
  r.loop:run()
  r:end_wall_recording()  -- (when the loop was stopped before the tree was down)
  if r.live then r.live:close() end
  if r.monitor then r.monitor:close(r.loop) end  -- the run's end reaches the pages
  local code = r.code or 1
  -- a run that aborted or failed to start keeps its daemons' logs, and says where (docs/processes.md)
  local kept, kerr = start.cleanup(r.ctx, code == 1 or code == 3)
  if kept then err_line(r, "the logs of this run's daemons are kept in ", kept, "/ (", table.concat(r.ctx.names, ".log, "),
    ".log)")
  elseif kerr then err_line(r, "could not keep the logs of this run's daemons: ", kerr) end
  return code
end

return M
