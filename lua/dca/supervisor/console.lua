-- dca.supervisor.console: the console that runs inside a supervisor (server side of `dca repl`).
--
-- Evaluates Lua like lua.c: `return <line>` first, then the line itself; a chunk whose parse ends at <eof>
-- waits for more lines. Each evaluation runs in a coroutine so that commands which ask other supervisors
-- (tree(), status(), expr() of a sub-group) wait for their answers without blocking the loop.
--
--   local repl = require("dca.supervisor.console").new(sup, { reload = function(what) return lines end })
--   repl:eval(line, function(output, more) end)   -- output: text to print; more: the chunk is incomplete
--   repl:complete(prefix)                          --> { candidates }
local supervisor = require "dca.supervisor"
local spec_mod = require "dca.supervisor.spec"

local M = {}

local ipairs, pairs, type, tostring, select, pcall, load = ipairs, pairs, type, tostring, select, pcall, load
local sformat, concat, sort = string.format, table.concat, table.sort
local cocreate, coresume, coyield, costatus = coroutine.create, coroutine.resume, coroutine.yield, coroutine.status
local traceback = debug.traceback

local HELP = [[
tree()                        the whole tree: each process with its state and host, how often it was
                              restarted, and each policy's budget ([strategy: used/intensity in T s used]);
                              the robot's emergency stop while latched
status(path)                  one process: kind, type, host, state
expr(path)                    a group's expression, running operands marked *X*
log(n)                        the last n events and commands of this supervisor (default 20)
event(path, "done", value)    inject a leaf event ("done" value | "aborted" reason)
abort(path)                   abort a process (its owner's algebra decides what follows); abort() the group
restart(path)                 a group: abort its expression and start it again (new event actions take
                                effect); a leaf: start its process anew from what is on disk now (rebuilt
                                code, config values), wired and running as before; nothing else stops. A
                                leaf sharing its process (--placement group|host) keeps that process's
                                code: refused, the leaf running on, when its package changed on disk. New
                                code whose ports misfit the connections is refused, never wired
upgrade(file, opts)           roll a new build of a controller package (DIR/NAME.dca.so) to the hosts of its
                                leaves, opts { canary = HOST, watch = SECONDS }: the canary first (default:
                                the first by name), its leaves restarted one by one onto it and watched
                                (default 5 s), then every other host. A crash or escalation on the canary
                                rolls it back and stops (docs/deploy.md)
activate(path, label)         activate / deactivate a connection set of a process
deactivate(path, label)
add_child(template, host)     a fleet (a template `name instances of Type(args) on { hosts };`): an instance of
                                the template on one of its hosts, started and run beside the group's expression,
                                supervised by the group's policy like any child (docs/supervision.md, "A fleet")
remove_child(path)            that instance stopped (actuators at zero) and ended; remove_child(template, host) too
fleet(path)                   the templates of a group (default: every group): hosts and instances
read(path, port)              a leaf's port: its latest sample and how many samples it has seen
stats(path)                   a leaf's timers: ticks, the period achieved (p50/p99/max, on its clock and on the
                                wall clock), how late ticks started, and overruns (periods skipped); on a
                                real-time thread its wake latency and execution time (p50/p99/p99.9/max)
blackbox(why)                 trigger the black box of `dca run --blackbox` now (its file names why)
estop()                       the emergency stop: every actuator held stopped from the next tick (docs/safety.md)
release("estop")              release it (it must be named); the commands take effect again from their next sample
reload()                      re-read the system file (and reload("modules") the supervisor's Lua)
config.get(key)               the configuration repository of this supervisor's host (replicated to all):
config.set(key, value)          a value; write one key (or config.set{ key = value, ... }: one transaction)
config.list(prefix)             the keys below prefix; the last n transactions and the conflicts (the
config.log(n)                   losing writes); print each change below prefix, local or replicated, as
config.watch(prefix)            a console line (config.unwatch(prefix) stops). A running leaf whose live
                                parameter is config("key") takes a new value of the key at once (a line says
                                so, or why not); another applies at its next start
clock()                       the simulated clock: its time, paused or running, and at what speed
pause()                       simulated time holds after the current tick (the world is the clock master)
resume()                      simulated time runs again, at the speed set
step()                        one tick (the world's period), then time holds; step("event"): time runs to the
                                end of the next tick at which a process ended or was lost (the supervisors'
                                transitions are made in that tick), then holds
speed(x)                      simulated seconds per wall second: 0.1 to 10, or "max" (as fast as the nodes allow)
help()                        this text
Any other Lua is evaluated here, in the supervisor; `return` is implied for expressions.
Paths are full (main.door.hit) or any unique suffix (door.hit).]]

local Repl = {}
Repl.__index = Repl

local function fmt_value(v)
  if type(v) == "string" then return v end
  if type(v) == "table" then
    local ok, s = pcall(require("dca.testing").show, v)
    return ok and s or tostring(v)
  end
  return tostring(v)
end

local function render_tree(node, out, depth)
  depth = depth or 0
  local pad = string.rep("  ", depth)
  local name = pad .. node.path:match("[^.]+$")
  local extra = ""
  if (node.restarts or 0) > 0 then extra = sformat("  restarted %d", node.restarts) end
  local pol = node.policy
  if pol then
    extra = extra .. sformat("  [%s: %d/%d in %g s used, %d restarts%s]", pol.strategy, pol.used, pol.intensity,
      pol.within, pol.total, pol.escalated and ", escalated" or "")
  end
  local e = depth == 0 and node.estop
  if e and e.latched then extra = extra .. sformat("  [EMERGENCY STOP by %s at %.3f s]", e.source, e.t) end
  out[#out + 1] = sformat("%-30s %-6s %-28s %s%s", name, node.kind, node.type .. "@" .. tostring(node.host),
    tostring(node.state), extra)
  for _, t in ipairs(node.fleet or {}) do
    out[#out + 1] = sformat("%-30s %-6s %-28s %d of %d hosts", pad .. "  " .. t.template, "fleet", t.type .. "@{" ..
      concat(t.hosts, ",") .. "}", #t.instances, #t.hosts)
  end
  for _, c in ipairs(node.children or {}) do render_tree(c, out, depth + 1) end
  return out
end
M.render_tree = render_tree

local find = supervisor.find

local function all_paths(node, list)
  list[#list + 1] = node.path
  for _, c in ipairs(node.children or {}) do all_paths(c, list) end
  return list
end

--- Resolves a full path or a unique suffix against the spec tree of `spec`. --> path | nil, err
function M.resolve(spec, path)
  if type(path) ~= "string" then return nil, "a path is a string such as \"main.arm.pd\"" end
  local hits, seen = {}, {}
  local function try(p)
    if p == path then hits = { p } return end
    -- (an added instance is both a child and its template's prepared instance: one hit)
    if #p > #path and p:sub(-#path - 1) == "." .. path and not seen[p] then seen[p] = true hits[#hits + 1] = p end
  end
  -- every process, a fleet's instances (added or not) and its templates
  spec_mod.walk_all(spec, function(n)
    try(n.path)
    for _, t in ipairs(n.kind == "group" and n.spec.templates or {}) do try(t.path) end
  end)
  for _, h in ipairs(hits) do if h == path then return path end end
  if #hits == 1 then return hits[1] end
  if #hits == 0 then return nil, sformat("no process '%s' under %s", path, spec.path) end
  return nil, sformat("'%s' is ambiguous: %s", path, concat(hits, ", "))
end

function M.new(sup, opts)
  opts = opts or {}
  local self = setmetatable({ sup = sup, buffer = nil, opts = opts }, Repl)
  self.env = self:_env()
  return self
end

-- Waits (inside the evaluation coroutine) for an asynchronous answer: fn(resume) calls resume(...) once.
local function await(fn)
  local co = coroutine.running()
  local result, sync, waiting = nil, false, false
  fn(function(...)
    result = table.pack(...)
    if waiting then
      local ok, err = coresume(co, table.unpack(result, 1, result.n))
      if not ok then error(err, 0) end
    else
      sync = true
    end
  end)
  if sync then return table.unpack(result, 1, result.n) end
  waiting = true
  return coyield()
end

-- The commands that show the tree: tree, status, expr, log. c: { sup, say, path_of, get_tree }
local function view_commands(env, c)
  local sup, say = c.sup, c.say
  function env.help() say(HELP) end
  function env.tree()
    say(concat(render_tree(c.get_tree(), {}), "\n"))
  end
  function env.status(p)
    local path = c.path_of(p)
    local n = find(c.get_tree(), path)
    if not n then error("no process " .. path, 0) end
    return sformat("%s: %s %s on host %s, %s", n.path, n.kind, n.type, tostring(n.host), n.state)
  end
  function env.expr(p)
    local path = c.path_of(p)
    local n = find(c.get_tree(), path)
    if not n or n.kind ~= "group" then error(path .. " is not a group", 0) end
    if not n.expr then return "(no internal_event_actions)" end
    return (n.expr:gsub("^%s+", ""):gsub("%s+$", ""))
  end
  function env.log(n)
    say(concat(sup:recent(n or 20), "\n"))
  end
  function env.fleet(p)
    local path = p ~= nil and c.path_of(p) or nil
    local lines = {}
    local function walk(n)
      if n.kind == "group" and (path == nil or n.path == path) then
        for _, t in ipairs(n.fleet or {}) do
          local inst = {}
          for i, x in ipairs(t.instances) do inst[i] = sformat("%s on %s (%s)", x.path, tostring(x.host), x.state) end
          lines[#lines + 1] = sformat("%s: %s on { %s }: %s", t.path, t.type, concat(t.hosts, ", "),
            #inst > 0 and concat(inst, ", ") or "no instance")
        end
      end
      for _, ch in ipairs(n.children or {}) do walk(ch) end
    end
    walk(c.get_tree())
    if #lines == 0 then return (path or sup.path) .. ": no template" end
    return concat(lines, "\n")
  end
end

-- The simulated clock's commands (docs/time.md "Pace"): clock, pause, resume, step, speed, as the supervisor's
-- `clock` request (the monitor's page sends the same).
local function clock_commands(env, c)
  local function clock(what, speed)
    local r = await(function(k) c.sup:handle({ type = "clock", what = what, speed = speed }, k) end)
    if not r or r.type == "error" then error(tostring(r and r.reason or "no answer"), 0) end
    return r.text
  end
  function env.clock() return clock("status") end
  function env.pause() return clock("pause") end
  function env.resume() return clock("go") end
  function env.step(to)
    if to ~= nil and to ~= "event" and to ~= "tick" then error("step(): one tick; step(\"event\"): to the next event", 0) end
    return clock(to == "event" and "step_event" or "step")
  end
  function env.speed(x)
    if x == nil then return clock("status") end
    return clock("speed", x)
  end
end

-- The commands that act: event, abort, restart, activate, deactivate, reload.
local function action_commands(env, c, reload)
  local sup, path_of = c.sup, c.path_of
  local function done(ok, err, text)
    if not ok then error(err, 0) end
    return text
  end
  local function inject(p, msg)
    local path = path_of(p)
    local ok, err = await(function(k) sup:inject(path, msg, k) end)
    return done(ok, err, sformat("%s: %s injected", path, msg.type))
  end
  function env.event(p, kind, value)
    if kind ~= "done" and kind ~= "aborted" then error("event kind is \"done\" or \"aborted\"", 0) end
    local msg = { type = kind }
    if kind == "done" then msg.value = value else msg.reason = value or "aborted from the REPL" end
    return inject(p, msg)
  end
  function env.abort(p)
    if p == nil then
      await(function(k) sup:abort(k, "aborted from the REPL") end)
      return sup.path .. ": aborted"
    end
    return inject(p, { type = "aborted", reason = "aborted from the REPL" })
  end
  function env.restart(p)
    local path = path_of(p)
    local ok, how = await(function(k) sup:restart(path, k) end)
    return done(ok, how, path .. ": restarted" .. (ok and how and " (" .. how .. ")" or ""))
  end
  local function set(p, label, what)
    local path = path_of(p)
    local ok, err = await(function(k) sup:switch(path, label, what, k) end)
    return done(ok, err, sformat("%s[%s]: %sd", path, tostring(label), what))
  end
  function env.blackbox(why)
    if not (sup.rt and sup.rt.world) then error("blackbox: this supervisor reaches no world", 0) end
    local msg = { type = "blackbox", why = "REPL: " .. tostring(why or "on demand") }
    local r, err = await(function(k) sup.rt.world(msg, sup.timeouts.request, k) end)
    if not (r and r.t) then error("blackbox: " .. tostring(err or (r and r.reason)), 0) end
    return sformat("black box triggered (%s) at %.3f s", msg.why, r.t)
  end
  -- the emergency stop, through the supervisor's request (the root's hook in `dca run`)
  local function estop(what, name)
    local r = await(function(k) sup:handle({ type = what, what = name, source = "REPL" }, k) end)
    if not r or r.type == "error" then error(tostring(r and r.reason or "no answer"), 0) end
    return r.text
  end
  function env.estop() return estop("estop") end
  function env.release(name) return estop("release", name) end
  -- a fleet's instances (dca.supervisor.fleet)
  function env.add_child(p, host)
    local path = path_of(p)
    if type(host) ~= "string" then error("add_child(template, host): the host is a string such as \"r1\"", 0) end
    local ok, r = await(function(k) sup:add_child(path, host, k) end)
    return done(ok, r, sformat("%s: added on host %s", tostring(r), host))
  end
  function env.remove_child(p, host)
    local path = path_of(p)
    local ok, r = await(function(k) sup:remove_child(path, host, k) end)
    return done(ok, r, sformat("%s: removed", tostring(r)))
  end
  -- a rolling upgrade of a controller package (dca.supervisor.upgrade): its lines, done or rolled back
  function env.upgrade(file, o)
    if type(file) ~= "string" or (o ~= nil and type(o) ~= "table") then
      error('upgrade("DIR/NAME.dca.so", { canary = "HOST", watch = SECONDS })', 0)
    end
    o = o or {}
    local _, text = await(function(k)
      require("dca.supervisor.upgrade").run(sup, { file = file, canary = o.canary, watch = o.watch }, k)
    end)
    return text
  end
  function env.activate(p, label) return set(p, label, "activate") end
  function env.deactivate(p, label) return set(p, label, "deactivate") end
  function env.reload(what)
    if not reload then error("reload is offered by the root supervisor (dca run)", 0) end
    c.say(concat(await(function(k) reload(what, k) end), "\n"))
  end
end

--- A number of microseconds as text: "840 us", "10.000 ms", "1.250 s".
local function us_text(us)
  us = tonumber(us) or 0
  if us >= 1e6 then return sformat("%.3f s", us / 1e6) end
  if us >= 1000 then return sformat("%.3f ms", us / 1000) end
  return sformat("%.0f us", us)
end
M.us_text = us_text

--- A leaf's `stats` reply (host/node.cpp) as lines: one per timer, with its achieved period when it is periodic.
function M.format_stats(path, r)
  local lines = { sformat("%s (%s clock):", path, tostring(r.clock)) }
  local intervals = {}
  for _, iv in ipairs(r.intervals or {}) do intervals[tostring(iv.name) .. "@" .. tostring(iv.period_s)] = iv end
  for _, t in ipairs(r.timers or {}) do
    local period = (t.period_s or 0) > 0 and ("every " .. us_text(t.period_s * 1e6)) or "once"
    lines[#lines + 1] = sformat("  %s %s%s: %d ticks, late p50 %s p99 %s max %s, overruns %d", tostring(t.name),
      period, t.active and "" or " (stopped)", t.count or 0, us_text(t.p50_us), us_text(t.p99_us),
      us_text(t.max_us), t.missed or 0)
    local iv = intervals[tostring(t.name) .. "@" .. tostring(t.period_s)]
    if iv and (iv.clock.n or 0) > 0 then
      lines[#lines + 1] = sformat("    period achieved p50 %s p99 %s max %s; on the wall clock p50 %s p99 %s max %s",
        us_text(iv.clock.p50_us), us_text(iv.clock.p99_us), us_text(iv.clock.max_us), us_text(iv.wall.p50_us),
        us_text(iv.wall.p99_us), us_text(iv.wall.max_us))
    end
  end
  local rt = r.rt
  if type(rt) == "table" then  -- the leaf runs on its node's real-time thread (docs/time.md, "Real time")
    local w, x = rt.wake or {}, rt.exec or {}
    local period = (rt.period_s or 0) > 0 and ("every " .. us_text(rt.period_s * 1e6)) or "no period yet"
    lines[#lines + 1] = sformat("  real-time thread %s: %d runs %s, overruns %d (periods missed %d)",
      tostring(rt.thread), rt.runs or 0, period, rt.overruns or 0, rt.missed or 0)
    lines[#lines + 1] = sformat("    wake latency p50 %s p99 %s p99.9 %s max %s; execution p50 %s p99 %s max %s",
      us_text(w.p50_us), us_text(w.p99_us), us_text(w.p999_us), us_text(w.max_us), us_text(x.p50_us),
      us_text(x.p99_us), us_text(x.max_us))
  end
  if #lines == 1 then lines[2] = "  no timers" end
  return concat(lines, "\n")
end

-- The commands that look at a leaf's data: read, stats (answered by its node).
local function data_commands(env, c)
  local sup, path_of = c.sup, c.path_of
  local async = require "dca.async"
  local function ask_leaf(p, msg)
    local path = path_of(p)
    local n = find(c.get_tree(), path)
    if not n then error("no process " .. path, 0) end
    if n.kind ~= "leaf" then error(path .. " is a group: " .. msg.type .. " asks a leaf", 0) end
    local r, err = await(function(k) sup:to_leaf(path, msg, sup.timeouts.request, k) end)
    local ok, why = async.outcome(r, err)
    if not ok then error(path .. ": " .. tostring(why), 0) end
    return r, path
  end
  function env.read(p, port)
    if type(port) ~= "string" then error("read(path, port): the port's name", 0) end
    local r = ask_leaf(p, { type = "read", port = port })
    local v = r.value
    if type(v) == "table" and #v == 1 then v = v[1] end
    return v, sformat("(%d samples)", r.count or 0)
  end
  function env.stats(p)
    local r, path = ask_leaf(p, { type = "stats" })
    return M.format_stats(path, r)
  end
end

-- config.get/set/list/log/watch/unwatch: the configuration repository of this supervisor's host.
local function config_commands(sup)
  local config_text = require "dca.config"  -- render, format_log
  local function repo()
    if not sup.rt.config_client then error("this supervisor has no configuration repository", 0) end
    local c, err = await(function(k) sup.rt.config_client(k) end)
    if not c then error(err, 0) end
    return c
  end
  -- calls fn(c, k) on the repository's client and waits for k's answer; an error raises
  local function ask(fn)
    local c = repo()
    local r, err = await(function(k) fn(c, k) end)
    if err then error(err, 0) end
    return r, c
  end
  local function what(prefix) return prefix and prefix ~= "" and prefix or "every key" end
  local cmd = {}
  function cmd.get(key) return (ask(function(c, k) c:get(key, k) end)) end
  function cmd.set(key, value)
    local values = type(key) == "table" and key or { [key] = value }
    local r = ask(function(c, k) c:set(values, k) end)
    return config_text.format_set(r)
  end
  function cmd.list(prefix)
    local lines = {}
    for _, e in ipairs(ask(function(c, k) c:list(prefix, k) end)) do
      lines[#lines + 1] = e.key .. " = " .. config_text.render(e.value)
    end
    return #lines > 0 and concat(lines, "\n") or "(no keys)"
  end
  function cmd.log(n) return config_text.format_log((ask(function(c, k) c:log(n or 20, k) end))) end
  function cmd.watch(prefix)
    local _, c = ask(function(c, k) c:watch(prefix or "", function(ev)
      sup:say("config: %s = %s (written on %s)", tostring(ev.key), config_text.render(ev.value), tostring(ev.origin))
    end, k) end)
    return sformat("watching %s on host %s", what(prefix), tostring(c.host))
  end
  function cmd.unwatch(prefix)
    ask(function(c, k) c:unwatch(prefix or "", k) end)
    return "stopped watching " .. what(prefix)
  end
  return cmd
end

-- The console's environment: the commands above, print, sup, and the globals.
function Repl:_env()
  local repl, sup = self, self.sup
  local c = { sup = sup }
  function c.path_of(p)
    if p == nil then return sup.path end
    local r, err = M.resolve(sup.spec, p)
    if not r then error(err, 0) end
    return r
  end
  function c.get_tree() return await(function(k) sup:tree(k) end) end
  function c.say(...) repl:_print(...) end
  local env = { print = c.say, sup = sup, config = config_commands(sup) }
  view_commands(env, c)
  action_commands(env, c, repl.opts.reload)
  clock_commands(env, c)
  data_commands(env, c)
  return setmetatable(env, { __index = _G })
end

function Repl:_print(...)
  local parts = {}
  for i = 1, select("#", ...) do parts[i] = fmt_value((select(i, ...))) end
  self.out[#self.out + 1] = concat(parts, "\t")
end

local function incomplete(err)
  return err and err:sub(-5) == "<eof>"
end

-- The commands that only show something: typed bare (`help`, `tree`), they run as if called; so do the clock's
-- (pause, resume, step: as in a debugger, and undone by the next). The others (abort, estop, restart, ...) act
-- on the system, so a bare name gets a hint rather than a function's address.
local BARE = { help = true, tree = true, status = true, expr = true, log = true, clock = true, pause = true,
               resume = true, step = true, fleet = true }

--- Evaluates one line; cb(output, more) once (now, or later when the line waits for other supervisors).
function Repl:eval(line, cb)
  local bare = not self.buffer and line:match("^%s*([%a_][%w_]*)%s*$")
  if bare and type(rawget(self.env, bare)) == "function" then
    if BARE[bare] then line = bare .. "()"
    else cb(sformat("%s is a command: type %s(...) (help() lists the commands)", bare, bare), false) return end
  end
  local chunk = self.buffer and (self.buffer .. "\n" .. line) or line
  local fn, err = load("return " .. chunk, "=stdin", "t", self.env)
  if not fn then
    fn, err = load(chunk, "=stdin", "t", self.env)
    if not fn then
      if incomplete(err) then self.buffer = chunk cb("", true) return end
      self.buffer = nil
      cb(err, false)
      return
    end
  end
  self.buffer = nil
  self.out = {}
  local out = self.out
  local function finish(res)
    if res[1] then
      local parts = {}
      for i = 2, res.n do parts[#parts + 1] = fmt_value(res[i]) end
      if #parts > 0 then out[#out + 1] = concat(parts, "\t") end
    else
      out[#out + 1] = tostring(res[2])
    end
    cb(concat(out, "\n"), false)
  end
  -- the coroutine reports its own end, whoever resumes it last (here, or an answer awaited by a command)
  local co = cocreate(function()
    finish(table.pack(xpcall(fn, function(e)
      if type(e) == "string" and not e:find("\n") and not e:find("^stdin:") then return e end
      -- the traceback of the typed code only (not the console's own frames)
      local tb = traceback(tostring(e), 2)
      local keep = {}
      for l in tb:gmatch("[^\n]+") do
        if l:find("xpcall", 1, true) then break end
        keep[#keep + 1] = l
      end
      return table.concat(keep, "\n")
    end)))
  end)
  local ok, err2 = coresume(co)
  if not ok then out[#out + 1] = tostring(err2) cb(concat(out, "\n"), false) end
end

--- Completion candidates for `prefix` (the word being typed): REPL functions, globals, and process paths.
function Repl:complete(prefix)
  local out, seen = {}, {}
  local function add(s) if s:sub(1, #prefix) == prefix and not seen[s] then seen[s] = true out[#out + 1] = s end end
  for k in pairs(self.env) do if type(k) == "string" then add(k) end end
  for k in pairs(_G) do if type(k) == "string" then add(k) end end
  -- fields of a table: config.g -> config.get
  local tname = prefix:match("^([%a_][%w_]*)%.")
  local t = tname and (rawget(self.env, tname) or _G[tname])
  if type(t) == "table" then
    for k in pairs(t) do if type(k) == "string" then add(tname .. "." .. k) end end
  end
  spec_mod.walk(self.sup.spec, function(n)
    add(n.path)
    local rel = n.path:sub(#self.sup.path + 2)
    if rel ~= "" then add(rel) end
  end)
  sort(out)
  return out
end

M.HELP = HELP
M.supervisor = supervisor
--- The console hook of dca.supervisor (opts.console): the console of `sup`, reloading through
--- sup.reload_hook (set by `dca run`).
function M.hook(sup)
  return M.new(sup, { reload = sup.reload_hook })
end

return M
