-- dca.supervisor.spec: the group spec a supervisor receives, and the pure walks over it.
--
-- A group spec is a plain table that survives msgpack (strings, numbers, booleans, lists, maps): the parent
-- hands it to a child supervisor over the control plane (never a file path).
--
--   spec = {
--     path = "main.door", type = "DoorOpenSystem", host = "h2",     -- full path, process type, host name
--     file = "door.dca", line = 12, col = 1,                         -- where the type is defined
--     expr = "MotionControl , (...)", expr_line = 40, expr_col = 5, -- internal_event_actions (nil: none)
--     children = {                                                  -- in declaration order
--       { name = "hit", path = "main.door.hit", kind = "leaf", type = "Threshold", host = "h1",
--         args = { 2.5 },                                           -- the .dca arguments after the host;
--                                                                   -- { config = "door.stop_distance" }
--                                                                   -- for config("door.stop_distance")
--         params = { { name = "distance", type = "number",          -- the manifest's parameters (if known);
--                      live = true } },                              --   live: changes while it runs
--         package = "door", system_dir = "/abs/dir",                -- a package's type: its package, and the
--                                                                   -- .dca file's folder (dca.load.spec)
--         standby = { "h1b" },                                      -- its standby hosts in order (the group's
--                                                                   --   `standby hit on h1b;`), nil: none
--         rt = { priority = 80, cpu = 1 } },                        -- its group's rt { } (or an ancestor's), nil:
--                                                                   --   none (docs/time.md, "Real time")
--       { name = "mc", path = "main.door.mc", kind = "group", type = "MotionControl", host = "h3",
--         spec = <the child's group spec> },
--     },
--     hosts = { "h2", "h2b" },                                       -- host, then its standby hosts in order
--                                                                   --   (host { h2, h2b }; failover uses them)
--     supervision = { strategy = "one_for_one",                      -- its supervision { } section resolved
--                     intensity = 3, within = 10,                    --   (dca.lang.model.policy: defaults filled
--                     on = { crash = true, lost = true, aborted = false } } | nil,  -- in); nil: none declared
--                                                                   --   (today's behaviour: faults go to the algebra)
--     fence = { fence = 5, margin = 1 },                             -- fencing (seconds; docs/supervision.md,
--                                                                   --   "Fencing"); nil in hand-made specs: 5, 1
--     external_io = { { alias = "Vel", instance = "mc", port = "In" }, ... },
--     templates = { { name = "lights", path = "main.lights", type = "Light", kind = "leaf" | "group",
--                     hosts = { "r1", "r2" },                       -- the hosts an instance may be added on
--                     instances = { <a child as above, named lights_r1, on r1>, ... } } } | nil,
--                                                                  -- (instances[i] is the one on hosts[i])
--                                                                  -- (docs/supervision.md, "A fleet":
--                                                                  --   dca.supervisor.fleet adds them)
--     sets = { { instance = "forcedata", label = "lbl1",
--                connections = { { from = "forcedata", out = "Out1", to = "hit", ["in"] = "In1" } } } },
--   }
--
--   spec_mod.from_model(tree, file, default_host) --> spec (tree: dca.lang.model.build's checked instance tree)
--   spec_mod.validate(spec)                       --> { message, ... } (connections that do not resolve)
--   spec_mod.set_id(group_path, instance, label)  --> "<group path>:<instance>[<label>]"
--   spec_mod.endpoint(spec, instance, port)       --> leaf path, port | nil, err  (follows external_io)
--   spec_mod.wiring(spec)   --> { { set =, src =, out =, dst =, ["in"] = }, ... } (leaf ports, every set)
--   spec_mod.route(spec, leaf_path)               --> the direct child (table) whose subtree holds the leaf
--   spec_mod.walk(spec, fn)                       -- fn(node, depth) for the group and every descendant
--   spec_mod.walk_all(spec, fn)                   -- the same, and every template's prepared instances
--   spec_mod.hosts(spec)                          --> sorted list of the host names used in the tree
--   spec_mod.resolve_leaf(child, client, cb)      -- cb(child with its config("key") arguments read) | cb(nil, err)
local M = {}

local ipairs, pairs, type, tostring, sformat = ipairs, pairs, type, tostring, string.format
local sort, concat = table.sort, table.concat

--- The id of a connection set: `<group path>:<instance>[<label>]` (ARCHITECTURE.md, nodes and the data plane).
function M.set_id(group_path, instance, label)
  return group_path .. ":" .. instance .. "[" .. label .. "]"
end

local function child_by_name(spec, name)
  for _, c in ipairs(spec.children) do
    if c.name == name then return c end
  end
end
M.child = child_by_name

--- Follows external_io aliases down from `instance, port` of group `spec` to a real leaf port.
function M.endpoint(spec, instance, port)
  local c = child_by_name(spec, instance)
  if not c then return nil, sformat("%s: no instance '%s'", spec.path, tostring(instance)) end
  local depth = 0
  while c.kind == "group" do
    depth = depth + 1
    if depth > 1000 then return nil, sformat("%s: external_io aliases loop", c.path) end
    local g, found = c.spec, nil
    for _, x in ipairs(g.external_io or {}) do
      if x.alias == port then found = x break end
    end
    if not found then
      return nil, sformat("%s: no external_io '%s' in group %s", c.path, tostring(port), g.type)
    end
    c = child_by_name(g, found.instance)
    if not c then return nil, sformat("%s: external_io '%s' names no instance '%s'", g.path, port, found.instance) end
    port = found.port
  end
  return c.path, port
end

--- Every connection of this group (not of its sub-groups) resolved to leaf ports, in declaration order.
function M.wiring(spec)
  local out, errs = {}, {}
  for _, s in ipairs(spec.sets or {}) do
    local id = M.set_id(spec.path, s.instance, s.label)
    for _, k in ipairs(s.connections) do
      local src, sport = M.endpoint(spec, k.from, k.out)
      local dst, dport = M.endpoint(spec, k.to, k["in"])
      if not src then errs[#errs + 1] = sport end
      if not dst then errs[#errs + 1] = dport end
      if src and dst then out[#out + 1] = { set = id, src = src, out = sport, dst = dst, ["in"] = dport } end
    end
  end
  if #errs > 0 then return nil, errs end
  return out
end

--- The direct child of `spec` whose subtree holds the leaf `leaf_path` (or the leaf itself).
function M.route(spec, leaf_path)
  for _, c in ipairs(spec.children) do
    if c.path == leaf_path then return c end
    local p = c.path .. "."
    if c.kind == "group" and leaf_path:sub(1, #p) == p then return c end
  end
end

--- Calls fn(node, depth) for the group itself (a spec, kind "group") and each descendant node, depth first.
function M.walk(spec, fn, depth)
  depth = depth or 0
  fn({ name = spec.path:match("[^.]+$"), path = spec.path, kind = "group", type = spec.type, host = spec.host,
       spec = spec }, depth)
  for _, c in ipairs(spec.children) do
    if c.kind == "group" then M.walk(c.spec, fn, depth + 1) else fn(c, depth + 1) end
  end
end

--- M.walk, then the same over every prepared instance of every template of the tree (a fleet's instances may
--- be added while it runs: what is done to the tree's nodes before it starts is done to them too).
function M.walk_all(spec, fn, depth)
  M.walk(spec, function(n, depth)
    fn(n, depth)
    for _, t in ipairs(n.kind == "group" and n.spec.templates or {}) do
      for _, c in ipairs(t.instances) do
        if c.kind == "group" then M.walk_all(c.spec, fn, depth + 1) else fn(c, depth + 1) end
      end
    end
  end, depth)
end

--- The host names used anywhere in the tree (standby hosts included), sorted.
function M.hosts(spec)
  local seen, list = {}, {}
  local function add(h) if h and not seen[h] then seen[h] = true list[#list + 1] = h end end
  M.walk(spec, function(n)
    add(n.host)
    -- the standby hosts too: a child fails over to them (dca.supervisor.failover), so their daemons must run
    for _, h in ipairs(n.standby or {}) do add(h) end
    for _, h in ipairs(n.spec and n.spec.hosts or {}) do add(h) end
    -- a template's hosts too: an instance may be added on any of them while the system runs
    for _, t in ipairs(n.spec and n.spec.templates or {}) do
      for _, c in ipairs(t.instances) do
        if c.kind == "group" then for _, h in ipairs(M.hosts(c.spec)) do add(h) end else add(c.host) end
      end
    end
  end)
  sort(list)
  return list
end

--- Counts of a tree: groups, leaves, connections.
function M.count(spec)
  local g, l, k = 0, 0, 0
  M.walk(spec, function(n)
    if n.kind == "group" then
      g = g + 1
      for _, s in ipairs(n.spec.sets or {}) do k = k + #s.connections end
    else l = l + 1 end
  end)
  return g, l, k
end

---------------------------------------------------------------------------------------------- from the model

-- A deep copy of plain data (nil stays nil): the spec shares nothing with the model.
local function copy(v)
  if type(v) ~= "table" then return v end
  local t = {}
  for k, x in pairs(v) do t[k] = copy(x) end
  return t
end
M.copy = copy

-- A group's rt { } as {priority, cpu}, else its parent's (`inherited`; docs/time.md, "Real time").
local function rt_of(proc, inherited)
  if not proc.rt then return inherited end
  local rt = {}
  for _, cl in ipairs(proc.rt.clauses) do rt[cl.kw] = cl.value end
  return rt
end

--- The spec of a dca.lang.model tree (checked, arguments bound, hosts resolved). `file` names the source for
--- messages. A group without a host (the root of a file without host { }) gets `default_host`; one without
--- rt { } gets its parent's (`parent_rt`).
function M.from_model(node, file, default_host, parent_rt)
  local proc = node.process or {}
  local host = node.host or default_host
  local spec = {
    path = node.path, type = node.type, host = host, file = file, line = proc.line, col = proc.col,
    children = {}, external_io = {}, sets = {}, hosts = { host }, supervision = copy(node.supervision),
    rt = copy(rt_of(proc, parent_rt)),
    fence = copy(node.fence),
  }
  for i = 2, #(node.hosts or {}) do spec.hosts[i] = node.hosts[i] end
  local actions = proc.actions
  if actions and actions.text then
    -- the parser's expression text has its comments blanked out (positions kept)
    spec.expr = actions.expr and actions.expr.text or actions.text
    spec.expr_line, spec.expr_col = actions.text_line or actions.line, actions.text_col or actions.col
    if not spec.expr:find("%S") then spec.expr = nil end
  end
  local function entry(c)
    if c.kind == "group" then
      local cs = M.from_model(c, file, host, spec.rt)
      return { name = c.name, path = c.path, kind = "group", type = c.type, host = cs.host, spec = cs }
    else
      local args = {}
      for i, v in ipairs(c.params or {}) do args[i] = v end
      -- the type's parameter names and types, when its manifest is known: a `config("key")` argument is
      -- resolved at start and its value checked against them (errors name the parameter)
      local info
      if c.manifest and c.manifest.params then
        info = {}
        for i, pm in ipairs(c.manifest.params) do
          info[i] = type(pm) == "table" and { name = pm.name, type = pm.type, live = pm.live or nil }
                    or { name = tostring(pm) }
        end
      end
      return { name = c.name, path = c.path, kind = "leaf", type = c.type, host = c.host, args = args, params = info,
               package = c.manifest and c.manifest.package or nil, standby = copy(c.standby), rt = copy(spec.rt) }
    end
  end
  for _, c in ipairs(node.children or {}) do spec.children[#spec.children + 1] = entry(c) end
  -- templates (docs/supervision.md, "A fleet"): each host's instance prepared, none in `children` until added
  for _, t in ipairs(node.templates or {}) do
    spec.templates = spec.templates or {}
    local tpl = { name = t.name, path = t.path, type = t.type, kind = t.kind, hosts = copy(t.hosts), instances = {},
                  line = t.line, col = t.col }
    for i, c in ipairs(t.instances) do tpl.instances[i] = entry(c) end
    spec.templates[#spec.templates + 1] = tpl
  end
  for _, x in ipairs(proc.external_io or {}) do
    spec.external_io[#spec.external_io + 1] = { alias = x.alias, instance = x.instance, port = x.port }
  end
  for _, st in ipairs(proc.internal_connections or {}) do
    local conns = {}
    for _, k in ipairs(st.connections or {}) do
      conns[#conns + 1] = { from = k.from, out = k.out, to = k.to, ["in"] = k["in"] }
    end
    spec.sets[#spec.sets + 1] = { instance = st.instance, label = st.label, connections = conns }
  end
  if not node.parent and not spec.host then
    -- a root without host { } (and no default) runs on the first host its tree uses
    local first = M.hosts(spec)[1] or "localhost"
    M.walk(spec, function(n)
      if n.kind == "group" and not n.spec.host then n.spec.host, n.spec.hosts[1] = first, first end
    end)
    M.walk(spec, function(n)
      if n.kind == "group" then
        for _, c in ipairs(n.spec.children) do if c.kind == "group" then c.host = c.spec.host end end
      end
    end)
  end
  return spec
end

--- Every connection of the tree must resolve to leaf ports: a list of messages (empty when all do).
function M.validate(spec)
  local errs = {}
  M.walk(spec, function(n)
    if n.kind == "group" then
      local _, e = M.wiring(n.spec)
      for _, m in ipairs(e or {}) do errs[#errs + 1] = m end
    end
  end)
  return errs
end

--- A child ready to start: a leaf's `config("key")` arguments read through `client` (a dca.config client, or
--- anything with get(self, key, cb)) and checked against its parameters (dca.config.resolve_controller_params),
--- the one way both runtimes resolve them. cb(child) unchanged when it has none, cb(a view of child with the
--- read `args`), or cb(nil, err naming the parameter and the key).
function M.resolve_leaf(child, client, cb)
  local config = require "dca.config"
  if child.kind ~= "leaf" or not config.has_params(child.args) then cb(child) return end
  config.resolve_controller_params(child.args, client, function(args, err)
    if not args then cb(nil, err) return end
    cb(setmetatable({ args = args }, { __index = child }))
  end, { params = child.params })
end

return M
