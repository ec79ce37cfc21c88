-- dca.supervisor.requests: the requests a supervisor answers (from its parent, `dca run`, a console), one entry
-- per type in M.HANDLERS, as lang/check.lua dispatches supervision clauses. Each handler is
-- fn(sup, msg, reply) and calls reply(msg) once: {type = "ok", ...} | {type = "error", reason = "..."}.
--
--   requests.handle(sup, msg, reply)       -- dispatches msg by msg.type; an unknown type is refused, naming those
--                                          --   there are
--   requests.inject(sup, path, msg, cb)    -- an event as if the process at `path` had sent it to its owner
--   requests.switch(sup, path, label, what, cb)  -- a connection set of the process at `path` (de)activated
--   requests.update(sup, spec, cb)         -- a new version of the group's spec (a reload). cb(lines)
local M = {}

local algebra = require "dca.algebra"
local async = require "dca.async"
local spec_mod = require "dca.supervisor.spec"
local taps = require "dca.supervisor.taps"

local ipairs, pairs, type, tostring, tonumber = ipairs, pairs, type, tostring, tonumber
local sformat = string.format
local concat, sort = table.concat, table.sort

-- reply(ok) for a cb(ok, err) operation.
local function done_by(reply)
  return function(ok, err) reply(ok and { type = "ok" } or { type = "error", reason = err }) end
end

-- reply(r) for a cb(reply | nil, err) request passed on.
local function passed_on(reply)
  return function(r, err) reply(r or { type = "error", reason = err }) end
end

-- The console of `repl` and `complete` requests, made on first use (opts.console of dca.supervisor.new).
local function console_of(sup, reply)
  if sup.repl then return sup.repl end
  if not sup.console then reply({ type = "error", reason = sup.path .. " has no console" }) return nil end
  sup.repl = sup.console(sup)
  return sup.repl
end

M.HANDLERS = {
  -- the spec came with the DCAS's creation; a configure message may also carry it
  configure = function(sup, _, reply)
    sup:configure(function(ok, err)
      if ok then reply({ type = "ok" }) else
        sup:shutdown(function() reply({ type = "error", reason = err }) end)
      end
    end)
  end,
  -- answered once everything the start ran has answered its own run (a whole subtree is running)
  run = function(sup, msg, reply)
    sup.event_at = tonumber(msg.at)
    local answered = false
    local ok, err = sup:run_expr(msg.init, function(started)
      if started and not answered then answered = true reply({ type = "ok" }) end
    end)
    sup.event_at = nil
    if not ok and not answered then answered = true reply({ type = "error", reason = err }) end
  end,
  abort = function(sup, _, reply) sup:abort(function() reply({ type = "ok" }) end) end,
  shutdown = function(sup, _, reply) sup:shutdown(function() reply({ type = "ok" }) end) end,
  node = function(sup, msg, reply) sup:to_leaf(msg.leaf, msg.msg, sup.timeouts.request, passed_on(reply)) end,
  tree = function(sup, _, reply) sup:tree(function(tr) reply({ type = "ok", tree = tr }) end) end,
  inject = function(sup, msg, reply) sup:inject(msg.path, msg.msg, done_by(reply)) end,
  -- ok {note}: how a leaf was restarted, when that says something (a leaf in a shared node: restart.code_check);
  -- own_process: a leaf in a shared node moves to a process of its own (a package upgrade)
  restart = function(sup, msg, reply)
    sup:restart(msg.path, function(ok, how)
      reply(ok and { type = "ok", note = how } or { type = "error", reason = how })
    end, { own_process = msg.own_process == true })
  end,
  -- a fleet's instances (dca.supervisor.fleet): ok {path} of the instance
  add_child = function(sup, msg, reply)
    sup:add_child(msg.path, msg.host, function(ok, r) reply(ok and { type = "ok", path = r } or { type = "error", reason = r }) end)
  end,
  remove_child = function(sup, msg, reply)
    sup:remove_child(msg.path, msg.host, function(ok, r) reply(ok and { type = "ok", path = r } or { type = "error", reason = r }) end)
  end,
  switch = function(sup, msg, reply) sup:switch(msg.path, msg.label, msg.what, done_by(reply)) end,
  ports = function(sup, msg, reply) taps.request(sup, msg, reply) end,
  tap = function(sup, msg, reply) taps.request(sup, msg, reply) end,
  ping = function(sup, _, reply) reply({ type = "ok", path = sup.path, state = sup.state }) end,
  stats = function(sup, msg, reply)
    -- {leaf = PATH}: that leaf's node's stats {} (its timers; on a real-time thread, rt: host/node.h)
    if type(msg.leaf) == "string" then return sup:to_leaf(msg.leaf, { type = "stats" }, nil, passed_on(reply)) end
    if msg.path and msg.path ~= sup.path then sup:_forward(msg.path, msg, passed_on(reply)) return end
    reply({ type = "ok", stats = sup.stats, path = sup.path })
  end,
  update = function(sup, msg, reply) sup:update(msg.spec, function(lines) reply({ type = "ok", lines = lines }) end) end,
  -- one key (or a table of them, one transaction) written to the configuration repository: the monitor's
  -- config_set, a value already read as a literal; a refusal is an error with the repository's reason
  config_set = function(sup, msg, reply)
    if type(msg.key) ~= "string" and type(msg.key) ~= "table" then
      reply({ type = "error", reason = "config_set: a key (or a table of keys and values)" }) return
    end
    if not sup.rt.config_client then
      reply({ type = "error", reason = sup.path .. " has no configuration repository" }) return
    end
    sup.rt.config_client(function(c, err)
      if not c then reply({ type = "error", reason = tostring(err) }) return end
      local values = type(msg.key) == "table" and msg.key or { [msg.key] = msg.value }
      c:set(values, function(r, serr)
        if not r then reply({ type = "error", reason = tostring(serr) }) return end
        reply({ type = "ok", text = require("dca.config").format_set(r) })
      end)
    end)
  end,
  -- the emergency stop (docs/safety.md): pressed or released by a console (the REPL, the monitor) through the
  -- root's hook (`dca run`: the world, or the driver), else its runtime's world; ok {t, text}
  estop = function(sup, msg, reply) M.estop(sup, "estop", msg, reply) end,
  release = function(sup, msg, reply) M.estop(sup, "release", msg, reply) end,
  -- a press or release, from the parent: remembered, passed on to the child groups
  estop_event = function(sup, msg, reply) M.estop_event(sup, msg, false) reply({ type = "ok" }) end,
  clock = function(sup, msg, reply) M.clock(sup, msg, reply) end,
  -- a rolling upgrade of a controller package (dca.supervisor.upgrade): ok {lines} | error (its lines)
  upgrade = function(sup, msg, reply)
    -- (the file's bytes come with the request: a path here would read this machine's files)
    local req = { name = msg.name, data = msg.data, canary = msg.canary, watch = msg.watch }
    require("dca.supervisor.upgrade").run(sup, req, function(ok, text)
      reply(ok and { type = "ok", text = text } or { type = "error", reason = text })
    end)
  end,
  repl = function(sup, msg, reply)
    local repl = console_of(sup, reply)
    if repl then repl:eval(msg.line or "", function(out, more) reply({ type = "ok", output = out, more = more }) end) end
  end,
  complete = function(sup, msg, reply)
    local repl = console_of(sup, reply)
    if repl then reply({ type = "ok", candidates = repl:complete(msg.prefix or "") }) end
  end,
}

--- The emergency stop pressed (`what` "estop") or released ("release", msg.what naming "estop") from msg.source.
function M.estop(sup, what, msg, reply)
  local req = { type = what, source = tostring(msg.source or "console"), what = msg.what }
  if what == "release" and req.what ~= "estop" then
    reply({ type = "error", reason = "release: name what to release: release(\"estop\")" }) return
  end
  local function answer(r, err)
    if not r then reply({ type = "error", reason = tostring(err) }) return end
    local text = what == "estop" and (r.already and "already pressed by " .. tostring(r.source) or "pressed") or "released"
    reply({ type = "ok", t = r.t, text = sformat("emergency stop %s at %.3f s", text, tonumber(r.t) or 0) })
  end
  if sup.estop_hook then sup.estop_hook(req, answer) return end
  if not sup.rt.world then reply({ type = "error", reason = what .. ": " .. sup.path .. " reaches no robot" }) return end
  sup.rt.world(req, sup.timeouts.request, function(r, err) answer(async.outcome(r, err)) end)
end

-- The world's requests for the clock's commands (host/lockstep.h), by `what`.
local CLOCK = {
  pause = function() return { type = "hold" } end,
  go = function() return { type = "go" } end,
  step = function() return { type = "step", to = "tick" } end,
  step_event = function() return { type = "step", to = "event" } end,
  status = function() return { type = "status" } end,
  speed = function(msg)
    local s = msg.speed
    if s == "max" or s == 0 then return { type = "pace", speed = 0 } end
    s = tonumber(s)
    if not s or s ~= s or s < 0.1 or s > 10 then return nil, "speed: 0.1 to 10 (times real time), or \"max\"" end
    return { type = "pace", speed = s }
  end,
}

-- The clock's state as a line: "t = 3.250 s, paused" | "t = 3.250 s, running at 2x" | "..., running at max speed".
function M.clock_text(r)
  local speed = tonumber(r.speed) or 0
  local how = not r.running and "paused" or (speed > 0 and sformat("running at %gx", speed) or "running at max speed")
  if r.running and r.stepping then how = how .. ", stepping" end
  return sformat("t = %.3f s, %s", tonumber(r.t) or 0, how)
end

--- The simulated clock, from a console or the monitor (msg.what: pause | go | step | step_event | speed (msg.speed:
--- 0.1 to 10, or "max") | status), through the world, the clock master (docs/time.md "Pace"). A step is answered
--- once the step's tick is done (time held again), a step to the next event at once. Answers {type = "ok", t,
--- running, speed, stepping, text} with the clock's state after it.
function M.clock(sup, msg, reply)
  local make = CLOCK[msg.what]
  if not make then
    reply({ type = "error", reason = "clock: what is pause, go, step, step_event, speed or status" }) return
  end
  local req, err = make(msg)
  if not req then reply({ type = "error", reason = err }) return end
  local world = sup.clock_hook or (sup.rt and sup.rt.world and function(m, cb) sup.rt.world(m, sup.timeouts.request, cb) end)
  if not world then reply({ type = "error", reason = "clock: " .. sup.path .. " reaches no simulated world" }) return end
  local tries = 0
  local function state()
    world({ type = "status" }, function(r0, serr)
      local r, e = async.outcome(r0, serr)
      if not r then reply({ type = "error", reason = "clock: " .. e }) return end
      -- a step: its tick is done once the world says it is no longer stepping (bounded: at 0.1x a tick of a slow
      -- world takes a while; after that the answer says "stepping")
      tries = tries + 1
      if msg.what == "step" and r.stepping and tries < 1000 then state() return end
      reply({ type = "ok", t = tonumber(r.t), running = r.running and true or false, speed = tonumber(r.speed) or 0,
             stepping = r.stepping and true or false, text = M.clock_text(r) })
    end)
  end
  if req.type == "status" then state() return end
  world(req, function(r0, rerr)
    local r, e = async.outcome(r0, rerr)
    if not r then reply({ type = "error", reason = "clock: " .. e }) return end
    state()
  end)
end

--- A press or release of the emergency stop (ev {latched, t, source}): this supervisor's `estop` state, a line
--- (said at the press's time with `say`: the root; logged by the others), and the same to every child group.
function M.estop_event(sup, ev, say)
  sup.estop = { latched = ev.latched and true or false, t = tonumber(ev.t) or 0, source = tostring(ev.source) }
  local line = sformat("%s: emergency stop %s by %s at %.3f s", sup.path, ev.latched and "pressed" or "released",
    sup.estop.source, sup.estop.t)
  if say then
    sup.event_at = sup.estop.t  -- the line carries the press's time (so it is in the trace too)
    sup:say(line)
    sup.event_at = nil
  else
    sup:log(line)
  end
  for _, c in ipairs(sup.spec.children) do
    local ch = sup.children[c.name]
    if c.kind == "group" and ch and ch.handle then
      ch.handle.request({ type = "estop_event", latched = sup.estop.latched, t = sup.estop.t, source = sup.estop.source },
        sup.timeouts.request, function() end)
    end
  end
end

--- A request from the parent (or the REPL/`dca run` on the root). reply(msg) answers it.
function M.handle(sup, msg, reply)
  local fn = M.HANDLERS[msg.type]
  if fn then fn(sup, msg, reply) return end
  local names = {}
  for name in pairs(M.HANDLERS) do names[#names + 1] = name end
  sort(names)
  reply({ type = "error", reason = sformat("unknown request '%s' for supervisor %s (requests: %s)", tostring(msg.type),
    tostring(sup.path), concat(names, ", ")) })
end

--- Injects an event (from the REPL or a scenario) as if the process at `path` had sent it to its owner.
function M.inject(sup, path, msg, cb)
  local ch = sup:_via(path)
  if ch and ch.path == path then
    -- the process is told to stop first (its run is over as far as the algebra is concerned), then the
    -- event is taken as if it had sent it
    if ch.kind == "leaf" and ch.handle and ch.state == "running" then
      ch.handle.request({ type = "stop" }, sup.timeouts.stop, function() end)
    end
    sup.rt.defer(function() sup:child_message(ch.name, msg) end)
    cb(true)
  else
    sup:_forward(path, { type = "inject", path = path, msg = msg }, cb)
  end
end

--- Activates/deactivates the connection set `label` of the process at `path` (in the group that owns it).
function M.switch(sup, path, label, what, cb)
  local ch = sup:_via(path)
  if ch and ch.path == path then
    local id = spec_mod.set_id(sup.path, ch.name, label)
    if not (sup.set_sources and sup.set_sources[id]) then cb(nil, "no connection set " .. id) return end
    sup:_set(ch.name, label, what)
    cb(true)
  else
    sup:_forward(path, { type = "switch", path = path, label = label, what = what }, cb)
  end
end

local function same(a, b)
  if a == b then return true end
  if type(a) ~= "table" or type(b) ~= "table" then return false end
  for k, v in pairs(a) do if not same(v, b[k]) then return false end end
  for k in pairs(b) do if a[k] == nil then return false end end
  return true
end

--- Takes a new version of this group's spec (a reload): event actions changed take effect at the group's
--- next start; structural changes are reported (they need the system started again). cb(lines).
function M.update(sup, new, cb)
  local lines = {}
  local old = sup.spec
  local name = sup.path .. " (" .. tostring(new.type) .. ")"
  local function shape(sp)
    local t = { children = {}, external_io = sp.external_io, sets = sp.sets, host = sp.host, type = sp.type,
                hosts = sp.hosts }
    for _, c in ipairs(sp.children) do
      -- (a fleet's added instances are no change of the file: dca.supervisor.fleet)
      if not (sp == old and require("dca.supervisor.fleet").owns(sup, c.name)) then
        t.children[#t.children + 1] = { c.name, c.kind, c.type, c.host, c.args, c.standby }
      end
    end
    t.templates = {}
    for i, x in ipairs(sp.templates or {}) do t.templates[i] = { x.name, x.type, x.hosts } end
    return t
  end
  if not same(shape(old), shape(new)) then
    lines[#lines + 1] = name .. ": processes or connections changed; takes effect when the system is started again"
  end
  if not same(old.supervision, new.supervision) then
    -- a policy is data: the new one applies from the next fault on (the restarts so far still count)
    sup.spec.supervision = new.supervision
    lines[#lines + 1] = name .. ": supervision policy changed; in effect now"
  end
  if old.expr ~= new.expr then
    local e, err = algebra.parse(new.expr or "")
    if not e then
      lines[#lines + 1] = sformat("%s: new event actions rejected: %s", name, err)
    else
      sup.spec.expr, sup.spec.expr_line, sup.spec.expr_col = new.expr, new.expr_line, new.expr_col
      if sup.state == "running" then
        sup.pending_expr = e
        lines[#lines + 1] = name .. ": event actions changed; takes effect at next start (or restart(\"" ..
          sup.path .. "\") now)"
      else
        sup.expr = e
        lines[#lines + 1] = name .. ": event actions changed; takes effect at next start"
      end
    end
  end
  M.update_children(sup, new, lines, cb)
end

-- The new specs of the sub-groups handed to their supervisors, their lines added to `lines`. cb(lines)
function M.update_children(sup, new, lines, cb)
  local j = async.join(function() cb(lines) end)
  for _, c in ipairs(new.children) do
    local ch = sup.children[c.name]
    if c.kind == "group" and ch and ch.kind == "group" and ch.handle then
      local k = j.add()
      ch.handle.request({ type = "update", spec = c.spec }, sup.timeouts.request, function(r, err)
        if r and r.lines then for _, l in ipairs(r.lines) do lines[#lines + 1] = l end
        else lines[#lines + 1] = sformat("%s: not updated: %s", c.path, r and r.reason or tostring(err)) end
        k(true)
      end)
    end
  end
  j.close()
end

return M
