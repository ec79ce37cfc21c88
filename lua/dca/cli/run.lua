-- `dca run FILE.dca`: checks the system, starts its hosts' daemons (or uses a hosts file), the root DCAS
-- in this process, brings the tree up (start, connect, confirm), runs it and reports every transition.
-- Exit code: 0 when the root expression ends DONE, 1 when it ends ABORTED (with the path and reason),
-- 2 on bad usage or check errors, 3 when the start fails, 130 after Ctrl-C.
local core = require "dca.core"
local supervisor, srt = require "dca.supervisor", require "dca.supervisor.net"
local hosts_mod, start = require "dca.launch.hosts", require "dca.launch.start"
local args_mod = require "dca.cli.args"

local M = {}

local ipairs, tostring, tonumber, sformat = ipairs, tostring, tonumber, string.format

M.summary = "run a .dca system: start its hosts and supervisor tree, run it, report each transition"
M.usage = [=[usage: dca run FILE.dca [--root NAME] [--hosts FILE] [--repl] [--watch] [--timeout S] [--quiet]
                    [--config FILE | --no-config] [--set KEY=VALUE]... [--state-dir DIR]
                    [--sim WORLD [--seed N] [--door-width W] [--record FILE.csv] [--jammed] [--realtime]]

Checks FILE.dca (errors stop here, nothing is started), starts one local daemon per host name on 127.0.0.1
(or uses the daemons named in --hosts, lines of "name address"), starts the supervisor tree, shows one line
per group as it comes up and one per process transition, and runs the root expression.
  --root NAME     the root process (default: main)
  --hosts FILE    daemons already running: "name address" per line
  --config FILE   the system's configuration defaults (`key = value` lines, Lua literals): the keys the
                  repository lacks are written to it before the start (default: FILE.config beside
                  FILE.dca, when there is one); a parameter config("key") reads the repository of its host
  --no-config     no defaults file
  --set KEY=VALUE write KEY into the repository before the start, whatever it holds (repeatable)
  --state-dir DIR the local daemons keep their repositories in DIR/<host> and find them there next time
                  (default: a fresh directory for this run, removed at the end)
  --sim WORLD     run in simulated time: the daemons on the simulated clock, the world (`dca sim --serve
                  --world WORLD`, e.g. door) started through the first host's daemon before the tree, its
                  device ports wired to the leaves that have them, time started when the root runs; the
                  lines carry the simulated time and the end prints the world's summary (door angle,
                  simulated and wall time, each step's start and end, and the control periods achieved
                  by the leaves of every MotionControl group: intervals between their MainCalc calls on the
                  simulated and on the wall clock, p50/p99/max)
  --seed N, --door-width W, --record FILE.csv   passed to the world (see `dca sim --help`)
  --jammed        passed to the world: the door handle's latch never releases (a fault to test against)
  --realtime      passed to the world: simulated time is paced to the wall clock (the nodes stay in
                  lock-step with it), so the wall-clock periods in the summary are the real control periods
  --repl          open a console on the root supervisor once the system runs
  --watch         reload the system file when it is saved (inotify)
  --timeout S     stop with an error when the start does not finish within S seconds (default 30)
  --quiet         no progress lines; only the outcome
Exit code 0 when the root expression ends DONE, 1 when ABORTED, 2 for usage or check errors, 3 when the
start fails, 130 after Ctrl-C. Ctrl-C stops the whole tree, most recently started first.]=]

local OPTIONS = {
  ["--root"] = "value", ["--hosts"] = "value", ["--sim"] = "value", ["--seed"] = "number",
  ["--door-width"] = "number", ["--record"] = "value", ["--jammed"] = "flag", ["--realtime"] = "flag",
  ["--timeout"] = "number", ["--repl"] = "flag", ["--watch"] = "flag", ["--quiet"] = "flag",
  ["--config"] = "value", ["--no-config"] = "flag", ["--state-dir"] = "value", ["--set"] = "list:sets",
}

-- The options that exclude each other or need another: the first broken rule. --> error text | nil
local function rule_broken(o)
  if not o.file then return "which .dca file?" end
  if (o.seed or o.door_width or o.record or o.jammed) and not o.sim then
    return "--seed, --door-width, --record and --jammed go with --sim WORLD"
  end
  if o.config and o.no_config then return "--config and --no-config exclude each other" end
  if o.state_dir and o.hosts then return "--state-dir is for the local daemons, not those of --hosts" end
  if o.realtime and not o.sim then return "--realtime goes with --sim WORLD" end
end

--- The options of argv. --> o | nil, error text
local function parse_args(args)
  local o, err = args_mod.parse(args, "dca run", OPTIONS)
  if not o then return nil, err end
  o.file, o.timeout = o[1], o.timeout or 30
  for _, a in ipairs(o.sets or {}) do
    local k, v = require("dca.config").parse_assignment(a)
    if not k then return nil, "dca run: --set: " .. v end
    o.set = o.set or {}
    o.set[k] = v
  end
  local broken = rule_broken(o)
  if broken then return nil, "dca run: " .. broken end
  if o.record and o.record:sub(1, 1) ~= "/" then o.record = (os.getenv("PWD") or ".") .. "/" .. o.record end
  return o
end

--- Reads, parses and checks FILE and builds the spec of its root. --> spec | nil, error text
function M.load(file, root)
  return require("dca.load").spec(file, { root = root })
end

-- A run: its options, spec, start context (dca.launch.start), the consoles following its lines, its exit code.
local Run = {}
Run.__index = Run

local function err_line(...) io.stderr:write("dca run: ", ...) io.stderr:write("\n") end

-- Writes a line for the person: to the consoles following the root (with --repl they own the terminal and
-- print it above their prompt), else to stdout.
function Run:emit(text)
  if srt.to_followers(self.followers, text) > 0 and self.o.repl then return end
  io.stdout:write(text, "\n")
  io.stdout:flush()
end

-- A progress line, stamped with the world's time (with --sim, in order) or the wall time since the start.
function Run:say(line, at)
  local s = self.ctx.sim
  if s and s.world:connected() then
    s:stamp(line, function(t, l) if not self.o.quiet then self:emit(sformat("[sim %8.3f] %s", t, l)) end end, at)
  elseif not self.o.quiet then
    self:emit(sformat("[%7.3f] %s", core.now() - self.t0, line))
  end
end

-- The root's outcome line to stderr (or the consoles), in order with the stamped lines.
function Run:say_aborted(msg)
  local text = sformat("%s: ABORTED at %s: %s", self.spec.path, tostring(msg.path), tostring(msg.reason))
  local function out(t)
    if not (self.o.repl and srt.to_followers(self.followers, t) > 0) then io.stderr:write(t, "\n") end
  end
  local s = self.ctx.sim
  if s and s.world:connected() then s:stamp(text, function(t) out(sformat("[sim %8.3f] %s", t, text)) end)
  else out(text) end
end

-- What the root reports: its lines and its outcome (which ends the run unless a console holds it).
function Run:report(msg)
  if msg.type == "log" then self:say(msg.line, msg.at)
  elseif msg.type == "done" then
    self:say(sformat("%s: DONE %s", self.spec.path, supervisor.show(msg.value)))
    if not self.o.repl then self.code = 0 self:wind_up() end
  elseif msg.type == "aborted" then
    self:say_aborted(msg)
    if not self.o.repl then self.code = 1 self:wind_up() end
  end
end

-- The tree, then the world stopped, then the loop.
function Run:down()
  local s = self.ctx.sim
  self.sup:shutdown(function()
    if s then s.world:stop(function() self.loop:stop() end) else self.loop:stop() end
  end)
end

-- The end of a run: the world's summary (with --sim), then down.
function Run:wind_up()
  local s = self.ctx.sim
  if not s then self:down() return end
  s:summary(core.now() - self.t0, function(lines)
    for _, l in ipairs(lines) do self:emit(l) end
    self:down()
  end)
end

-- Stops everything with exit code `c` (unless one is set), bounded: the daemons are killed after the loop.
function Run:stop_all(c)
  if self.code == nil then self.code = c end
  self:down()
  core.after(15, function() self.loop:stop() end)
end

-- The root listens for consoles (`dca repl main`) and registers its path with its host's daemon.
function Run:listen()
  local key, hosts, spec = self.ctx.key, self.ctx.hosts, self.spec
  self.listener = core.listen("127.0.0.1:0", srt.key_opts(key), function(ch)
    ch:on_message(function(msg, id) srt.console(ch, id, msg, self.sup, self.followers) end)
    ch:on_close(function() self.followers[ch] = nil end)
  end)
  local root_daemon = hosts[spec.host]
  if not (self.listener and root_daemon) then return end
  require("dca.clients.daemon").connect(root_daemon, srt.key_opts(key), function(d)
    if not d then return end
    self.ctx.rt.root_daemon = d
    d:register(spec.path, { control = self.listener:address() })
    self:say(sformat("console: dca repl %s --daemon %s --key %s", spec.path, root_daemon, tostring(key)))
  end)
end

-- reload: the file again (validated first; on an error the old version keeps running), or the modules.
function Run:reload(what, cb)
  local reload = require "dca.reload"
  if what == "modules" then cb(reload.modules()) return end
  reload.system(self.sup, what or self.o.file, { root = self.o.root }, function(lines, err)
    if not lines then lines = { "reload refused, the running version is kept:", err }
    elseif #lines == 0 then lines = { "no change" } end
    cb(lines)
  end)
end

-- --watch: the file reloaded when it is saved.
function Run:watch()
  local w, werr = core.watch_file(self.o.file)
  if not w then err_line("--watch: ", werr) return end
  core.every(0.2, function()
    if w:changed() then
      self:reload(nil, function(lines) for _, l in ipairs(lines) do self:say("reload: " .. l) end end)
    end
  end)
end

-- --repl: `dca repl` on the root's console endpoint, in its own process on this terminal (line editing owns
-- the terminal while this loop keeps the system running); its exit ends the run.
function Run:open_console()
  local key = self.ctx.key
  local cmd = sformat("%s repl %s%s </dev/tty >/dev/tty 2>&1 & echo $!", hosts_mod.sh_quote(self.ctx.exe),
    hosts_mod.sh_quote(self.listener:address()), key and (" --key " .. hosts_mod.sh_quote(key)) or "")
  local p = io.popen(cmd, "r")
  local pid = p and tonumber((p:read("a") or ""):match("%d+"))
  if p then p:close() end
  if not pid then err_line("could not start the console") return end
  local watch
  watch = core.every(0.1, function()
    if hosts_mod.alive(pid) then return end
    watch:cancel()
    local st = self.sup.outcome and self.sup.outcome.status
    self:stop_all(st == "done" and 0 or (st == "aborted" and 1 or 130))
  end)
end

-- The root runs; simulated time starts once every process the start ran has its run (a repeatable start).
function Run:run_root()
  self:say(self.spec.path .. ": the whole tree is configured: run")
  self.sup:run_expr(nil, function()
    local s = self.ctx.sim
    if not s then return end
    s.world:go(function(r, gerr)
      if not r then err_line("the world did not start its time: ", tostring(gerr)) self:stop_all(3) end
    end)
  end)
  if self.o.repl and self.listener then self:open_console() end
end

-- The tree comes up (start, connect, confirm) within --timeout, then runs.
function Run:bring_up()
  local deadline = core.after(self.o.timeout, function()
    if self.sup.state == "starting" or self.sup.state == "new" then
      err_line(sformat("the start did not finish within %gs", self.o.timeout))
      self:stop_all(3)
    end
  end)
  self.sup:configure(function(ok, err)
    if not ok then err_line("start failed: ", tostring(err)) self:stop_all(3) return end
    deadline:cancel()
    self:run_root()
  end)
end

-- The exit code when start step `step` failed (see dca.launch.start): usage and configuration errors 2.
local function start_code(o, step, kind)
  if step == "hosts" then return o.hosts and 2 or 3 end
  if step == "config" then return kind and 2 or 3 end
  if step == "sim_clock" then return 2 end
  return 3
end

-- With --sim: the daemons' clock checked (a hosts file) and the world started, then the tree comes up.
function Run:start_world()
  local ctx = self.ctx
  start.sequence(ctx, { "sim_clock", "world" }, function(ok, err, step, kind)
    if not ok then
      err_line(tostring(err))
      self.code = start_code(self.o, step, kind)
      if ctx.sim then ctx.sim.world:stop(function() self.loop:stop() end) else self.loop:stop() end
      return
    end
    if ctx.sim then
      ctx.sim.world.on_lost = function(reason)
        err_line(reason, " (the nodes on its clock stop with it)")
        if self.code == nil then self.code = 1 end
      end
    end
    self:bring_up()
  end)
end

-- Hosts and configuration (dca.launch.start). --> true | nil, exit code
function Run:prepare()
  if not core.loop or not core.connect then
    io.stderr:write("dca run: this dca has no control plane (dca.core.loop/connect)\n")
    return nil, 3
  end
  local done, code
  start.sequence(self.ctx, { "hosts", "config" }, function(ok, err, step, kind)
    done = true
    if ok then return end
    err_line(err)
    start.cleanup(self.ctx)
    code = start_code(self.o, step, kind)
  end)
  assert(done, "hosts and config do not wait")
  if code then return nil, code end
  return true
end

function M.main(args)
  local o, perr = parse_args(args)
  if not o then return args_mod.usage_error(perr, M.usage) end
  local spec, err = M.load(o.file, o.root)
  if not spec then io.stderr:write(err, "\n") return 2 end
  o.config = o.config or (not o.no_config and require("dca.config").defaults_file(o.file)) or nil
  o.check, o.summary, o.wait = true, true, o.timeout
  local r = setmetatable({ o = o, spec = spec, followers = {}, t0 = core.now() }, Run)
  r.ctx = start.context(spec, o, { say = function(line) r:say(line) end, report = function(msg) r:report(msg) end,
                                   log = function(line, at) r:say(line, at) end })
  local pok, code = r:prepare()
  if not pok then return code end
  r.loop = core.loop()
  r.sup = start.tree(r.ctx, spec.host)
  core.on_signal(function(sig) r:say("interrupted (SIG" .. tostring(sig) .. "): stopping") r:stop_all(130) end)
  r:listen()
  r.sup.reload_hook = function(what, cb) r:reload(what, cb) end
  if o.watch then r:watch() end
  r:start_world()
  r.loop:run()
  start.cleanup(r.ctx)
  return r.code or 1
end

return M
