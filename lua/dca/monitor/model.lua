-- dca.monitor.model: what the web monitor shows, as data (pure: no I/O, no clock, no dca.core).
--
-- The tree's processes (path, kind, type, host, state, restarts, the last fault), each group's expression as an
-- operator tree, the events of the run in time order (every transition: the timeline and the states at any
-- time come from them), the configuration repository, the last lines. Fed by whoever watches a run (a live
-- root, a console, a recording); read as a snapshot and as deltas (what changed since the last take).
--
--   local model = require "dca.monitor.model"
--   local m = model.new(root)   -- root: the system's root path ("main"), or nil: the first tree's
--   m:tree(tree, t)          -- the tree as Sup:tree gives it (hosts, states, expressions)
--   m:line(line, t)          -- a run's line ("main.a: running", "main.b: aborted: reason"), at time t (s)
--   m:set_config(key, text, origin)   -- a configuration value (as text) and where it was written
--   m:rt_leaves()            --> the paths of the leaves with an rt setting (the tree's `rt`)
--   m:rt(path, figures)      -- such a leaf's figures on its real-time thread (a node's stats {} rt): node.rt
--   m:clock{t, running, speed, stepping}  -- the world's clock (the clock master's status): t is then the world's
--                            -- time, not the last line's (a live run with --sim)
--   m:snapshot()             --> { nodes, exprs, events, config, lines, t, clock }
--   m:take_delta()           --> { nodes, exprs, events, config, lines, t, clock? } | nil when nothing changed
local algebra = require "dca.algebra"

local M = {}

local ipairs, pairs, tostring, type, tonumber = ipairs, pairs, tostring, type, tonumber
local smatch = string.match

--- Lines kept for a new page; events kept (the timeline's): the oldest go first past MAX_EVENTS, so a snapshot
--- stays well below the server's send bound however long a run lasts.
M.MAX_LINES, M.MAX_EVENTS = 300, 50000

-- The words of a transition line and what they mean for the process: its state, and whether the rest of the
-- line is a fault's reason.
local WORDS = {
  starting = "starting", started = "started", configured = "configured", running = "running",
  aborting = "aborting", stopped = "stopped", done = "done", aborted = "aborted", exited = "exited",
  lost = "lost", restarting = "restarting", restarted = "running",
  removed = "removed",  -- a fleet's instance removed (docs/supervision.md, "A fleet")
  DONE = "done", ABORTED = "aborted",  -- the root's outcome ("main: ABORTED at main.b: reason")
}
local FAULTS = { aborted = true, exited = true, lost = true, ABORTED = true }

local Model = {}
Model.__index = Model

--- A model of the system whose root is `root` (e.g. "main"): lines about other names ("world: ...") are kept as
--- lines but are no processes of the tree. Without a root, the first tree given names it.
function M.new(root)
  return setmetatable({ root = root, nodes = {}, order = {}, exprs = {}, events = {}, config = {}, lines = {},
                        t = 0, delta = nil }, Model)
end

-- Whether `path` is the root or below it.
function Model:_in_tree(path)
  local r = self.root
  return r ~= nil and (path == r or path:sub(1, #r + 1) == r .. ".")
end

-- The pending delta, made on first use.
function Model:_delta()
  local d = self.delta
  if not d then
    d = { nodes = {}, exprs = {}, events = {}, config = {}, lines = {} }
    self.delta = d
  end
  return d
end

-- An expression's operator tree for the page: { op, name, label } leaves, { op, kids } operators.
local function ast(node)
  if node.op == "leaf" then return { op = "leaf", name = node.name, label = node.label } end
  local kids = {}
  for i, k in ipairs(node.kids) do kids[i] = ast(k) end
  return { op = node.op, kids = kids }
end

--- The operator tree of expression text `text` (marks such as *A* removed). --> tree | nil
function M.expr_tree(text)
  if type(text) ~= "string" or text == "" then return nil end
  local e = algebra.parse((text:gsub("%*", "")))
  return e and ast(e.root) or nil
end

-- The process at `path`, made when new (kind and host unknown until the tree says).
function Model:_node(path)
  local n = self.nodes[path]
  if n then return n end
  n = { path = path, kind = "leaf", type = "", host = "", state = "new", restarts = 0,
        parent = smatch(path, "^(.*)%.[^.]+$") or "" }
  self.nodes[path] = n
  self.order[#self.order + 1] = path
  local parent = self.nodes[n.parent]
  if parent then parent.kind = "group" end
  return n
end

-- Marks node `n` changed in the delta.
function Model:_changed(n) self:_delta().nodes[n.path] = n end

-- An event: process `path` entered `state` at time `t` (with a fault's reason).
function Model:_event(path, state, t, fault)
  local n = self:_node(path)
  if n.state == state and not fault then return end
  n.state = state
  if fault then n.fault = fault end
  local ev = { t = t, path = path, state = state, fault = fault }
  local events = self.events
  events[#events + 1] = ev
  if #events > M.MAX_EVENTS then  -- the oldest tenth goes at once (one move per MAX_EVENTS / 10 events)
    self.events = table.move(events, M.MAX_EVENTS // 10 + 1, #events, 1, {})
  end
  local d = self:_delta()
  d.events[#d.events + 1] = ev
  self:_changed(n)
end

--- Takes the tree (as Sup:tree gives it) at time `t`: new processes, hosts, states, expressions.
function Model:tree(tree, t)
  self.root = self.root or tree.path
  local function walk(tn)
    local n = self:_node(tn.path)
    local kind, ty, host = tn.kind or n.kind, tostring(tn.type or ""), tostring(tn.host or "")
    if n.kind ~= kind or n.type ~= ty or n.host ~= host then
      n.kind, n.type, n.host = kind, ty, host
      self:_changed(n)
    end
    if tn.rt and not n.rt_thread then  -- a leaf with an rt setting: its figures are asked for (rt below)
      n.rt_thread = true
      self:_changed(n)
    end
    -- a group's templates (a fleet): each with its hosts and how many instances it has, for the page's buttons
    if tn.fleet then
      local f, keys = {}, {}
      for i, t in ipairs(tn.fleet) do
        local hosts = {}
        for j, h in ipairs(t.hosts or {}) do hosts[j] = tostring(h) end
        f[i] = { path = tostring(t.path), type = tostring(t.type), hosts = hosts, instances = #(t.instances or {}) }
        keys[i] = f[i].path .. "=" .. f[i].instances
      end
      local key = table.concat(keys, ",")
      if key ~= n.fleet_key then n.fleet, n.fleet_key = f, key self:_changed(n) end
    end
    if tonumber(tn.restarts) and tonumber(tn.restarts) ~= n.restarts then
      n.restarts = tonumber(tn.restarts)
      self:_changed(n)
    end
    if tn.state and tostring(tn.state) ~= n.state then self:_event(tn.path, tostring(tn.state), t or self.t) end
    if tn.kind == "group" and tn.expr and not self.exprs[tn.path] then
      local e = M.expr_tree(tn.expr)
      if e then self.exprs[tn.path] = e self:_delta().exprs[tn.path] = e end
    end
    for _, c in ipairs(tn.children or {}) do walk(c) end
  end
  walk(tree)
end

--- The leaves the tree said have an rt setting, in tree order.
function Model:rt_leaves()
  local out = {}
  for _, p in ipairs(self.order) do if self.nodes[p].rt_thread then out[#out + 1] = p end end
  return out
end

--- A leaf's figures on its node's real-time thread (its node's stats {} rt: host/node.h), for the page's table.
function Model:rt(path, r)
  if type(r) ~= "table" then return end
  local n = self:_node(path)
  local w, x = type(r.wake) == "table" and r.wake or {}, type(r.exec) == "table" and r.exec or {}
  local num = function(v) return tonumber(v) or 0 end
  n.rt = { runs = num(r.runs), period_s = num(r.period_s), overruns = num(r.overruns), missed = num(r.missed),
           wake_p50_us = num(w.p50_us), wake_p99_us = num(w.p99_us), wake_max_us = num(w.max_us),
           exec_p50_us = num(x.p50_us), exec_p99_us = num(x.p99_us), exec_max_us = num(x.max_us) }
  self:_changed(n)
end

--- Takes a line of the run at time `t` (seconds): kept, and a transition becomes an event.
function Model:line(line, t)
  line = tostring(line)
  t = tonumber(t) or self.t
  if t > self.t then self.t = t end
  local entry = { t = t, line = line }
  self.lines[#self.lines + 1] = entry
  if #self.lines > M.MAX_LINES then table.remove(self.lines, 1) end
  local d = self:_delta()
  d.lines[#d.lines + 1] = entry
  local path, word, rest = smatch(line, "^(%S+): (%a+)(.*)$")
  if rest == " whole tree is configured: run" then word = "running" end  -- the root's own start
  local state = word and WORDS[word]
  if not state or not self:_in_tree(path) then return end
  local n = self:_node(path)
  if word == "restarted" then n.restarts = n.restarts + 1 end
  local fault = FAULTS[word] and rest:match("^:?%s*(.+)$") or nil
  if word == "aborted" and fault and fault:match("^%(") then fault = fault:match("^%((.*)%)$") or fault end
  self:_event(path, state, t, fault)
end

--- A configuration value (rendered as text) written on `origin`.
function Model:set_config(key, text, origin)
  local c = { key = tostring(key), value = tostring(text), origin = origin and tostring(origin) or "" }
  self.config[c.key] = c
  self:_delta().config[c.key] = c
end

-- A map's values as a list, in the order of `order` (or sorted by key).
local function values(map, order)
  local out = {}
  if order then
    for _, k in ipairs(order) do if map[k] then out[#out + 1] = map[k] end end
    return out
  end
  local keys = {}
  for k in pairs(map) do keys[#keys + 1] = k end
  table.sort(keys)
  for _, k in ipairs(keys) do out[#out + 1] = map[k] end
  return out
end

--- The world's clock: its time (seconds), whether it runs, its speed (simulated s per wall s, 0 unpaced) and
--- whether a step is under way. Its time is the model's from now on (never back: lines may come later).
function Model:clock(c)
  local new = { t = tonumber(c.t) or 0, running = c.running and true or false, speed = tonumber(c.speed) or 0,
                stepping = c.stepping and true or false }
  local old = self.clock_state
  if new.t > self.t then self.t = new.t end
  if old and old.t == new.t and old.running == new.running and old.speed == new.speed
     and old.stepping == new.stepping then return end
  self.clock_state = new
  self:_delta().clock = new
end

--- Everything, for a page that just connected.
function Model:snapshot()
  return { nodes = values(self.nodes, self.order), exprs = self.exprs, events = self.events,
           config = values(self.config), lines = self.lines, t = self.t, clock = self.clock_state }
end

--- What changed since the last take (nil when nothing did).
function Model:take_delta()
  local d = self.delta
  if not d then return nil end
  self.delta = nil
  return { nodes = values(d.nodes, self.order), exprs = d.exprs, events = d.events, config = values(d.config),
           lines = d.lines, t = self.t, clock = d.clock }
end

return M
