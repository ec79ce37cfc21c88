-- dca.lang.model: a checked DCA file instantiated as a tree of instances with bound arguments, for the
-- supervisor (and for `dca check` / `dca graph`).
--
--   local model = require "dca.lang.model"
--   local tree, errors = model.build(ast, { root = "main", args = {}, host = nil, types = core.types(),
--                                           world = core.world_signals(SPEC) })
--   -- errors: the list from dca.lang.check (plus binding errors, then the port types of the tree's connections
--   -- and device ports: dca.lang.ports), each { line, col, path, msg }; nil tree then.
--
-- Every node of the tree:
--   { path = "main.dooropensyst.hit", name = "hit", type = "HitDetector",
--     kind = "group" | "leaf",
--     host = "c3.nada.kth.se",         -- leaf: its first argument; group: its host { } (else the parent's host;
--                                      --   the root without host { } has opts.host, possibly nil)
--     hosts = { "h1", "h1b" },          -- group: its host, then the standby hosts of its host { } (bound)
--     standby = { "h2b" } | nil,        -- leaf: its standby hosts (its group's `standby` clause, bound)
--     supervision = policy | nil,       -- group: its supervision section resolved (M.policy), nil without one
--     fence = { fence = s, margin = s }, -- group: its fencing (M.fence: its `fence` clause, or the defaults)
--     args = { v1, v2, ... },          -- every argument bound to a value, in order (leaf: host first)
--     params = { v2, ... },            -- leaf: the arguments after the host (what the controller gets)
--     bindings = { host1 = "c1..." },  -- group: its parameters by name
--     manifest = m | nil,              -- leaf: the registry's (or builtin) manifest when known
--     process = <AST process>,         -- group: its definition (instances, external_io, internal_connections,
--                                      --   actions.expr: the dca.algebra expression)
--     children = { node, ...; [name] = node }, -- group: its instances in declaration order and by name
--     templates = { tpl, ...; [name] = tpl },  -- group: its templates (docs/supervision.md, "A fleet"): tpl =
--                                      --   { name, path, type, kind, hosts = { bound host... }, instances =
--                                      --   { node, ...; [host] = node } (one prepared per host, named
--                                      --   M.instance_name(name, host), its host its first argument), line, col }
--     parent = node | nil, line, col }  -- where the instance is declared (the root: its process)
--
--   model.walk(tree, fn)            fn(node, depth) for every node, parents first
--   model.find(tree, path)          the node at "main.dooropensyst.hit", or nil
--   model.resolve(group, name, port)  the leaf port behind a child's port (follows external_io down)
--   model.connections(tree)         every connection resolved to leaf ports, with its set name
--                                   "<group path>:<instance>[<label>]" (ARCHITECTURE.md, nodes)
--   model.summary(tree)             counts for `dca check`'s summary line
--   model.policy(proc)              the supervision policy of a process definition (defaults filled in), or nil:
--                                   { strategy = "one_for_one", intensity = 1, within = 5 (seconds),
--                                     on = { crash = true, lost = true, aborted = false } }
local check = require "dca.lang.check"
local ports = require "dca.lang.ports"

local M = {}

local ipairs, pairs, type, tostring, sformat = ipairs, pairs, type, tostring, string.format

local function bind(a, env)
  if a.kind == "param" then return env[a.value] end
  if a.kind == "config" then return { config = a.value } end  -- resolved at start: dca.config.resolve_params
  return a.value
end

--- Whether the bound host v (the value of the argument a) cannot be used: not a string, or, bound through a
--- parameter (a literal string is dca.lang.check's), a string with a control character or not a host name.
--- --> nil when it can be used, else "" or ": why" to end the message with.
local function unusable_host(v, a)
  if type(v) ~= "string" then return "" end
  if a.kind ~= "param" then return nil end
  if v:find("%c") then return ": it holds a control character" end
  local why = check.host_name_problem(v)
  return why and (": " .. why)
end

local function shown(v)
  if type(v) ~= "string" then return tostring(v) end
  return (sformat("%q", v):gsub("\\\n", "\\n"))
end

--- The defaults of a supervision section's missing clauses (OTP's: one restart in five seconds).
M.POLICY_DEFAULTS = { strategy = "one_for_one", intensity = 1, within = 5, on = { "crash", "lost" } }

--- Fencing's defaults (docs/supervision.md, "Fencing"): a node whose supervisor has been silent `fence` seconds
--- stops; a standby starts `fence + margin` after the last renewal. 5 s: the heartbeat's bound of silence.
M.FENCE_DEFAULTS = { fence = 5, margin = 1 }

--- The fencing of the (checked) process definition `proc`: { fence = s, margin = s }, defaults filled in.
function M.fence(proc)
  local d = M.FENCE_DEFAULTS
  local f = { fence = d.fence, margin = d.margin }
  for _, cl in ipairs(proc.supervision and proc.supervision.clauses or {}) do
    if cl.kw == "fence" then
      f.fence = cl.within * (check.units[cl.unit or "s"] or 1)
      if cl.margin then f.margin = cl.margin * (check.units[cl.margin_unit or "s"] or 1) end
    end
  end
  return f
end

--- The supervision policy of the (checked) process definition `proc`, or nil when it declares none.
function M.policy(proc)
  local sec = proc.supervision
  if not sec then return nil end
  local d = M.POLICY_DEFAULTS
  local pol = { strategy = d.strategy, intensity = d.intensity, within = d.within,
                on = { crash = false, lost = false, aborted = false } }
  local kinds = d.on
  for _, cl in ipairs(sec.clauses) do
    if cl.kw == "strategy" then pol.strategy = cl.name
    elseif cl.kw == "intensity" then
      pol.intensity, pol.within = cl.count, cl.within * (check.units[cl.unit] or 1)
    elseif cl.kw == "restart" then
      kinds = {}
      for i, k in ipairs(cl.kinds) do kinds[i] = k.name end
    end
  end
  for _, k in ipairs(kinds) do pol.on[k] = true end
  return pol
end

-- The bound standby hosts of each leaf instance of `def` (its `standby` clauses): { [instance] = { host... } }.
local function standby_of(def, env, bind_host)
  local out = {}
  for _, cl in ipairs(def.supervision and def.supervision.clauses or {}) do
    if cl.kw == "standby" then
      local list = {}
      for i, a in ipairs(cl.hosts) do list[i] = bind_host(a, env, "standby host of leaf " .. cl.instance) end
      out[cl.instance] = list
    end
  end
  return out
end

-- The templates of process `def` (at `path`, its parameters bound in `env`): one prepared instance per host of
-- each one's set, none of them started (dca.supervisor.fleet adds them). instantiate(inst, name, values, host_arg)
-- makes a child; bind_host(a, env, what) binds a host argument or records why it cannot be one.
local function templates_of(def, defs, env, path, bind_host, instantiate)
  local out = {}
  for _, t in ipairs(def.templates or {}) do
    local tpl = { name = t.name, path = path .. "." .. t.name, type = t.type, kind = defs[t.type] and "group" or "leaf",
                  hosts = {}, instances = {}, line = t.line, col = t.col }
    for _, a in ipairs(t.hosts) do
      local h = bind_host(a, env, "host of template " .. t.name)
      if type(h) == "string" and not tpl.instances[h] then
        local values = { h }
        for i, x in ipairs(t.args) do values[i + 1] = bind(x, env) end
        local inst = instantiate(t, M.instance_name(t.name, h), values, a)
        tpl.hosts[#tpl.hosts + 1] = h
        tpl.instances[#tpl.instances + 1] = inst
        tpl.instances[h] = inst
      end
    end
    out[#out + 1] = tpl
    out[t.name] = tpl
  end
  return out
end

--- Checks `ast` (dca.lang.check, same opts) and instantiates the tree rooted at opts.root (default "main").
--- Returns the root node, or nil and the list of errors.
function M.build(ast, opts)
  opts = opts or {}
  local root_name = opts.root or "main"
  local copts = {}
  for k, v in pairs(opts) do copts[k] = v end
  copts.root = root_name
  local errors = check.check(ast, copts)
  if #errors > 0 then return nil, errors end
  local defs = ast.by_name
  local rootdef = defs[root_name]
  local manifest = check.manifests(opts)
  local args = opts.args or {}
  if #args ~= #rootdef.params then
    return nil, { { line = rootdef.line, col = rootdef.col, path = root_name,
                    msg = sformat("the root process '%s' takes %d arguments, %d given", root_name, #rootdef.params,
                                  #args) } }
  end
  local berrors = {}
  local function group(def, path, name, argv, parent_host, parent, decl)
    local env = {}
    for i, prm in ipairs(def.params) do env[prm.name] = argv[i] end
    -- a host argument bound, or an error naming what it is (`what`) and where it came from
    local function bind_host(a, benv, what)
      local v = bind(a, benv)
      local unusable = unusable_host(v, a)
      if unusable then
        local why = a.kind == "param" and sformat(" (its parameter '%s')", a.value) or ""
        local at = decl or a
        berrors[#berrors + 1] = { line = at.line, col = at.col, path = path,
                                  msg = sformat("the %s of %s is %s%s, not a host name%s", what, path, shown(v), why,
                                                unusable) }
      end
      return v
    end
    local host = parent_host
    if def.host then host = bind_host(def.host, env, "host") end
    local hosts = { host }
    for i, a in ipairs(def.standby_hosts or {}) do hosts[i + 1] = bind_host(a, env, "standby host") end
    local standby = standby_of(def, env, bind_host)
    local node = { path = path, name = name, type = def.name, kind = "group", host = host, hosts = hosts, args = argv,
                   bindings = env, process = def, children = {}, parent = parent, supervision = M.policy(def),
                   fence = M.fence(def),
                   line = decl and decl.line or def.line, col = decl and decl.col or def.col }
    -- the child `name` of instance (or template) `inst` with its arguments bound (`values`; a leaf's host first)
    local function instantiate(inst, name, values, host_arg)
      local cpath = path .. "." .. name
      local d = defs[inst.type]
      -- (a template's group instance runs its supervisor on its own host unless its host { } says otherwise)
      if d then return group(d, cpath, name, values, host_arg and values[1] or host, node, inst) end
      local params = {}
      for i = 2, #values do params[i - 1] = values[i] end
      local child = { path = cpath, name = name, type = inst.type, kind = "leaf", host = values[1], args = values,
                      params = params, manifest = manifest(inst.type), parent = node, line = inst.line,
                      col = inst.col, standby = standby[name] }
      local a = host_arg or inst.args[1]
      local unusable = a and unusable_host(values[1], a)
      if unusable then
        local why = a.kind == "param" and sformat(" (parameter '%s' of %s)", a.value, path) or ""
        berrors[#berrors + 1] = { line = a.line, col = a.col, path = cpath,
                                  msg = sformat("the host of leaf %s is %s%s, not a host name%s", cpath,
                                                shown(values[1]), why, unusable) }
      end
      return child
    end
    for _, inst in ipairs(def.instances) do
      local values = {}
      for i, a in ipairs(inst.args) do values[i] = bind(a, env) end
      local child = instantiate(inst, inst.name, values)
      node.children[#node.children + 1] = child
      node.children[inst.name] = child
    end
    node.templates = templates_of(def, defs, env, path, bind_host, instantiate)
    return node
  end
  local tree = group(rootdef, root_name, root_name, args, opts.host, nil, nil)
  if #berrors > 0 then return nil, berrors end
  local terrors = ports.check(tree, opts.world)
  if #terrors > 0 then return nil, terrors end
  return tree
end

--- The name of the instance of template `template` on host `host`: "lights_r1", "lights_c1_example" (a host's
--- characters other than letters, digits and '_' become '_').
function M.instance_name(template, host)
  return template .. "_" .. tostring(host):gsub("[^%w_]", "_")
end

--- Calls fn(node, depth) for every node, depth first, parents before children.
function M.walk(node, fn, depth)
  depth = depth or 0
  fn(node, depth)
  if node.children then
    for _, c in ipairs(node.children) do M.walk(c, fn, depth + 1) end
  end
end

--- The node at `path` ("main.dooropensyst.hit"), or nil.
function M.find(tree, path)
  if path == tree.path then return tree end
  local rest = path:sub(#tree.path + 2)
  if path:sub(1, #tree.path + 1) ~= tree.path .. "." then return nil end
  local node = tree
  for part in rest:gmatch("[^.]+") do
    node = node.children and node.children[part]
    if not node then return nil end
  end
  return node
end

--- The leaf port behind `port` of the child `name` of group `node`, following external_io aliases down
--- through groups. Returns leaf_node, port_name, or nil and a reason.
function M.resolve(node, name, port)
  local child = node.children and node.children[name]
  for _ = 1, 1000 do
    if not child then return nil, sformat("no instance '%s' in %s", tostring(name), node.path) end
    if child.kind == "leaf" then return child, port end
    local x = child.process.external_io[port]
    if not x then return nil, sformat("%s (%s) exports no port '%s'", child.path, child.type, tostring(port)) end
    node, name, port = child, x.instance, x.port
    child = node.children[name]
  end
  return nil, "external_io aliases nested too deeply at " .. node.path
end

--- Every connection of the tree resolved to leaf ports, in tree order:
--- { group = <group node>, owner = <instance name>, label = "lbl1", set = "<group path>:<owner>[<label>]",
---   from = <leaf node>, out = "Out", to = <leaf node>, ["in"] = "In", line =, col =,
---   written = the connection as the file has it: { from =, out =, to =, ["in"] = } (instances of the group) }.
--- Returns the list, or nil and a list of { line, col, path, msg } (an alias that leads nowhere).
function M.connections(tree)
  local out, errors = {}, {}
  M.walk(tree, function(n)
    if n.kind ~= "group" then return end
    for _, set in ipairs(n.process.internal_connections) do
      for _, c in ipairs(set.connections) do
        local from, op = M.resolve(n, c.from, c.out)
        local to, ip = M.resolve(n, c.to, c["in"])
        if from and to then
          out[#out + 1] = { group = n, owner = set.instance, label = set.label,
                            set = sformat("%s:%s[%s]", n.path, set.instance, set.label),
                            from = from, out = op, to = to, ["in"] = ip, line = c.line, col = c.col, written = c }
        else
          errors[#errors + 1] = { line = c.line, col = c.col, path = n.path, msg = from and ip or op }
        end
      end
    end
  end)
  if #errors > 0 then return nil, errors end
  return out
end

--- Counts for a one-line summary: { groups, instances, leaves, connections, templates, hosts = { sorted names } }
--- (a template's hosts among the hosts: an instance may run on each).
function M.summary(tree)
  local s = { groups = 0, instances = 0, leaves = 0, connections = 0, templates = 0, hosts = {} }
  local seen = {}
  local function host(h)
    if h ~= nil and not seen[h] then
      seen[h] = true
      s.hosts[#s.hosts + 1] = tostring(h)
    end
  end
  M.walk(tree, function(n, depth)
    if depth > 0 then s.instances = s.instances + 1 end
    if n.kind == "group" then
      s.groups = s.groups + 1
      for _, set in ipairs(n.process.internal_connections) do s.connections = s.connections + #set.connections end
      for _, t in ipairs(n.templates or {}) do
        s.templates = s.templates + 1
        for _, h in ipairs(t.hosts) do host(h) end
      end
    else
      s.leaves = s.leaves + 1
    end
    host(n.host)
  end)
  table.sort(s.hosts)
  return s
end

return M
