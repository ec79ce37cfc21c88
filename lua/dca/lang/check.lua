-- dca.lang.check: static checks over a parsed DCA file (dca.lang.parser), every error at once.
--
--   local errors = check.check(ast, {
--     root = "main",              -- the root process (default: "main" when the file has one)
--     types = core.types(),       -- optional registry: { [Type] = { inputs = {{name=}...}, outputs = ..., params = ... } }
--     manifest = function(type) end,  -- optional instead of `types`: a manifest or nil
--     packages = { [name] = { types = {...} } | { error = "..." } },  -- optional: the file's `use`d packages
--                                 -- as dca.load found them (an error is reported at its `use`)
--     elsewhere = { [Type] = "package" },  -- optional: types of loaded packages the file does not use (hints)
--     ambiguous = { [Type] = { "lab", "other" } },  -- optional: names several used packages define (lab.Type)
--     unused_packages = { "name", ... },   -- optional: packages on the search path the file does not use (hints)
--   })
--   -- errors: list of { line =, col =, path = "main.dooropensyst.hit", msg = "..." } in file order;
--   -- check.format(ast, e) -> "file:line:col: path: msg\n<source line>\n<caret>"
--
-- Process types: a type defined in the file is a group; any other type is a leaf (a controller). Timer and
-- Deadline are built-in leaves taking the host and one parameter (the duration in seconds). When a registry
-- is given (`types` or `manifest`), a type that is neither defined in the file, built in, nor known to the
-- registry is an error ("unknown process type", with "did you mean"); without a registry undefined types
-- are taken as leaves whose ports cannot be checked.
--
-- Leaves take their host as the first argument, then their parameters. Groups bind their arguments to
-- their declared parameters; a group's supervisor runs on its `host { }` (or its parent's host).
-- The expression of internal_event_actions names *instances* (motionctrl), never types (MotionControl).
local source = require "dca.lang.source"
local props = require "dca.verify.props"

local M = {}

local sformat, concat, sort = string.format, table.concat, table.sort
local ipairs, pairs, type, tostring = ipairs, pairs, type, tostring

--- Manifests of the built-in leaf types, for a check without the registry. The registry (dca.core.types(),
--- from the C++ controllers) is the source: its Timer and Deadline win whenever opts.types has them. These
--- stay because dca.lang runs without dca.core (plain Lua, `dca check --no-registry`, the golden tests, whose
--- texts name the parameter 'duration'); tests/lua/lang/check_test.lua holds them to the registry's shape.
M.builtins = {
  Timer = { inputs = {}, outputs = {}, params = { { name = "duration", type = "number" } }, builtin = true,
            ends = "done", ends_after = "duration" },
  Deadline = { inputs = {}, outputs = {}, params = { { name = "duration", type = "number" } }, builtin = true,
               ends = "aborted", ends_after = "duration" },
}

local function names_of(list)
  local out = {}
  for i, p in ipairs(list or {}) do out[i] = type(p) == "table" and p.name or tostring(p) end
  return out
end

local function listing(list)
  if #list == 0 then return "(none)" end
  return concat(list, ", ")
end

local function plural(n, one, many) return n == 1 and (n .. " " .. one) or (n .. " " .. (many or (one .. "s"))) end

-- ----------------------------------------------------------------------------------------- the context
-- Every pass reads and extends one context:
--   ctx = { ast, defs = ast.by_name, opts, errors = {...},
--           manifest = function(type) -> manifest | nil, registry_known, known_types = { sorted names },
--           path_of = { [process] = "main.inst..." }, first_def = { [name] = first process of that name },
--           scope = { [process] = { base, params = {[name]=true}, param_list, signature, first = {[inst]=inst},
--                                   inst_names = { sorted }, sets = {[instance\0label] = first set} } } }
-- A check is one pass (M.passes): a function(ctx) over the whole file, or each(function(ctx, p, sc)) run for
-- each process definition p with its scope sc. Errors are sorted by position at the end, so the order of the
-- passes that only report is free; those that fill the context come first.

--- The manifest lookup of check's opts: the registry (opts.types), then opts.manifest, then the builtins.
function M.manifests(opts)
  local registry, manifest_fn = opts.types, opts.manifest
  return function(t)
    if registry and registry[t] then return registry[t] end
    if manifest_fn then
      local m = manifest_fn(t)
      if m then return m end
    end
    return M.builtins[t]
  end
end

local function err(ctx, path, line, col, fmt, ...)
  ctx.errors[#ctx.errors + 1] = { line = line, col = col, path = path, msg = sformat(fmt, ...) }
end

local function guess_text(name, candidates)
  local guess = source.closest(name, candidates)
  return guess and sformat(" (did you mean '%s'?)", guess), guess
end

--- Calls report(item, first) for each item of list whose key(item) an earlier item already had.
local function each_repeat(list, key, report)
  local first = {}
  for _, item in ipairs(list) do
    local k = key(item)
    if first[k] then report(item, first[k]) else first[k] = item end
  end
  return first
end

-- ------------------------------------------------------------------------------------------ port lookup

local port_info
-- The export names of group `d`, without those known to go the other way than `want` ("input"/"output").
local function names_of_exports(ctx, d, want, depth)
  local out, seen = {}, {}
  for _, x in ipairs(d.external_io) do
    if not seen[x.alias] then
      seen[x.alias] = true
      local dir = want and port_info(ctx, d, x.instance, x.port, depth + 1) or "unknown"
      if dir == "unknown" or dir == want then out[#out + 1] = x.alias end
    end
  end
  return out
end

-- Direction of `port` on instance `iname` of process `proc`: "input" | "output" | "unknown" (no manifest)
-- or nil when the port does not exist; the second result lists the valid names for messages.
function port_info(ctx, proc, iname, port, depth, want)
  depth = depth or 0
  local inst = proc.instances[iname]
  if not inst or depth > 50 then return "unknown" end
  local d = ctx.defs[inst.type]
  if d then
    local x = d.external_io[port]
    if not x then return nil, { exports = names_of_exports(ctx, d, want, depth) } end
    return port_info(ctx, d, x.instance, x.port, depth + 1) or "unknown"
  end
  local m = ctx.manifest(inst.type)
  if not m then return "unknown" end
  for _, p in ipairs(m.inputs or {}) do if p.name == port then return "input" end end
  for _, p in ipairs(m.outputs or {}) do if p.name == port then return "output" end end
  return nil, { inputs = names_of(m.inputs), outputs = names_of(m.outputs) }
end

--- Reports an instance name that process p lacks, naming the instance whose type it is, or the likely one.
local function unknown_instance(ctx, p, sc, path, line, col, name, where)
  local tpl = p.templates and p.templates[name]
  if tpl then
    return err(ctx, path, line, col, "'%s' %s is a template (line %d): its instances are added at run time and run "
               .. "beside the expression, never named in it nor connected (add_child, docs/supervision.md)", name,
               where, tpl.line)
  end
  for _, inst in ipairs(p.instances) do
    if inst.type == name then
      return err(ctx, path, line, col, "unknown instance '%s' %s: '%s' is the type of instance '%s' (name the instance)",
                 name, where, name, inst.name)
    end
  end
  err(ctx, path, line, col, "unknown instance '%s' %s%s", name, where,
      guess_text(name, sc.inst_names) or sformat(" (instances: %s)", listing(sc.inst_names)))
end

-- ------------------------------------------------------------------------------------- the file's passes

--- The manifest lookup and every type name anyone knows (for "did you mean").
local function known_types(ctx)
  local opts = ctx.opts
  ctx.manifest = M.manifests(opts)
  ctx.registry_known = opts.types ~= nil or opts.manifest ~= nil
  local names = {}
  for _, p in ipairs(ctx.ast.processes) do names[#names + 1] = p.name end
  for t in pairs(M.builtins) do names[#names + 1] = t end
  for t in pairs(opts.types or {}) do names[#names + 1] = t end
  for _, t in ipairs(opts.type_names or {}) do names[#names + 1] = t end
  sort(names)
  ctx.known_types = names
end

--- The `use` statements: each package once, each found and loaded (opts.packages, when the caller loaded them).
local function uses(ctx)
  local packages = ctx.opts.packages
  each_repeat(ctx.ast.uses or {}, function(u) return u.name end, function(u, first)
    err(ctx, "use", u.line, u.col, "package '%s' is already used at line %d", u.name, first.line)
  end)
  if not packages then return end
  local reported = {}
  for _, u in ipairs(ctx.ast.uses or {}) do
    local pk = packages[u.name]
    if pk and pk.error and not reported[u.name] then
      reported[u.name] = true
      err(ctx, "use", u.line, u.col, "%s", pk.error)
    end
  end
end

--- The path of the first instance of each process definition from the root; a missing root is an error.
local function instance_paths(ctx)
  local defs, root_name = ctx.defs, ctx.opts.root
  if not root_name and defs.main then root_name = "main" end
  ctx.path_of = {}
  if not root_name then return end
  local root = defs[root_name]
  if not root then
    return err(ctx, root_name, 1, 1, "no process '%s' to run as the root%s", root_name,
               guess_text(root_name, names_of(ctx.ast.processes)) or "")
  end
  local path_of, queue, qi = ctx.path_of, { root }, 1
  path_of[root] = root_name
  while queue[qi] do
    local p = queue[qi]
    qi = qi + 1
    for _, inst in ipairs(p.instances) do
      local d = defs[inst.type]
      if d and not path_of[d] then
        path_of[d] = path_of[p] .. "." .. inst.name
        queue[#queue + 1] = d
      end
    end
  end
end

local function duplicate_definitions(ctx)
  ctx.first_def = each_repeat(ctx.ast.processes, function(p) return p.name end, function(p, first)
    err(ctx, p.name, p.line, p.col, "process '%s' is defined twice (first at line %d)", p.name, first.line)
  end)
end

--- What the per-process passes share about each process definition (see the context above).
local function scopes(ctx)
  ctx.scope = {}
  for _, p in ipairs(ctx.ast.processes) do
    local sc = { base = ctx.path_of[p] or p.name, params = {}, param_list = names_of(p.params),
                 first = {}, inst_names = {}, sets = {} }
    for _, prm in ipairs(p.params) do sc.params[prm.name] = true end
    sc.signature = sformat("%s(%s)", p.name, concat(sc.param_list, ", "))
    for _, inst in ipairs(p.instances) do
      if not sc.first[inst.name] then
        sc.first[inst.name] = inst
        sc.inst_names[#sc.inst_names + 1] = inst.name
      end
    end
    sort(sc.inst_names)
    for _, set in ipairs(p.internal_connections) do
      local key = set.instance .. "\0" .. set.label
      sc.sets[key] = sc.sets[key] or set
    end
    ctx.scope[p] = sc
  end
end

--- Recursion between process types: each cycle reported once, at the instance that closes it.
local function recursion(ctx)
  local state, stack = {}, {}   -- state: nil unvisited, 1 on the stack, 2 done
  local function visit(p)
    state[p] = 1
    stack[#stack + 1] = p
    for _, inst in ipairs(p.instances) do
      local d = ctx.defs[inst.type]
      if d and state[d] == 1 then
        local chain, on = {}, false
        for _, q in ipairs(stack) do
          on = on or q == d
          if on then chain[#chain + 1] = q.name end
        end
        chain[#chain + 1] = d.name
        err(ctx, (ctx.path_of[p] or p.name) .. "." .. inst.name, inst.type_line, inst.type_col,
            "recursive process types: %s (a process cannot contain itself)", concat(chain, " -> "))
      elseif d and not state[d] then
        visit(d)
      end
    end
    stack[#stack] = nil
    state[p] = 2
  end
  for _, p in ipairs(ctx.ast.processes) do
    if not state[p] and ctx.first_def[p.name] == p then visit(p) end
  end
end

-- ------------------------------------------------------------------------------ each process's passes

local function check_param_arg(ctx, p, sc, a, path)
  if a.kind == "param" and not sc.params[a.value] then
    err(ctx, path, a.line, a.col, "parameter '%s' is not declared: process %s%s", a.value, sc.signature,
        guess_text(a.value, sc.param_list) or "")
  end
  -- a numeral past the largest double reads as inf: refused here rather than run as "at once" or "never"
  if a.kind == "number" and (a.value == math.huge or a.value == -math.huge or a.value ~= a.value) then
    err(ctx, path, a.line, a.col, "number out of range (a number is at most about 1.8e308)")
  end
end

local function parameters(ctx, p, sc)
  each_repeat(p.params, function(prm) return prm.name end, function(prm)
    err(ctx, sc.base, prm.line, prm.col, "parameter '%s' is declared twice in process '%s'", prm.name, p.name)
  end)
  for _, d in ipairs(p.duplicate_sections) do
    err(ctx, sc.base, d.line, d.col, "section '%s' appears twice in process '%s' (first at line %d)", d.section,
        p.name, d.first_line)
  end
end

-- A host argument `a` of process p (its host { } or a standby host): a declared parameter or a string.
local function host_arg(ctx, p, sc, a, what)
  check_param_arg(ctx, p, sc, a, sc.base)
  if a.kind == "number" then
    err(ctx, sc.base, a.line, a.col, "%s must be a parameter or a string, not a number", what)
  end
end

local function process_host(ctx, p, sc)
  if not p.host then return end
  host_arg(ctx, p, sc, p.host, sformat("the host of process '%s'", p.name))
  for _, a in ipairs(p.standby_hosts or {}) do host_arg(ctx, p, sc, a, sformat("a standby host of process '%s'", p.name)) end
end

-- ------------------------------------------------------------------------------------ the supervision section
-- supervision { strategy S; intensity N in T s|ms; restart on KIND, ...; standby INST on HOST, ...; fence T; }: each
-- clause once (standby once per instance), known names, a whole number of restarts, a period above zero.

M.strategies = { "one_for_one", "one_for_all", "rest_for_one" }
M.fault_kinds = { "crash", "lost", "aborted" }
M.units = { s = 1, ms = 0.001 }
local function is_in(list, v) for _, x in ipairs(list) do if x == v then return true end end return false end

local SUPERVISION_CLAUSE = {}
function SUPERVISION_CLAUSE.strategy(ctx, p, sc, cl)
  if is_in(M.strategies, cl.name) then return end
  err(ctx, sc.base, cl.name_line, cl.name_col, "unknown strategy '%s'%s", cl.name,
      guess_text(cl.name, M.strategies) or sformat(" (strategies: %s)", concat(M.strategies, ", ")))
end
function SUPERVISION_CLAUSE.intensity(ctx, p, sc, cl)
  if math.type(cl.count) ~= "integer" or cl.count < 0 then
    err(ctx, sc.base, cl.count_line, cl.count_col, "the restart intensity is a whole number of restarts (0 or more), "
        .. "not %s", tostring(cl.count))
  end
  if not M.units[cl.unit] then
    err(ctx, sc.base, cl.unit_line, cl.unit_col, "unknown unit '%s' of the intensity's period (write s or ms)%s",
        cl.unit, guess_text(cl.unit, { "s", "ms" }) or "")
  end
  if not (cl.within > 0) or cl.within == math.huge then
    err(ctx, sc.base, cl.within_line, cl.within_col, "the intensity's period must be a positive number, not %s",
        tostring(cl.within))
  end
end
function SUPERVISION_CLAUSE.restart(ctx, p, sc, cl)
  each_repeat(cl.kinds, function(k) return k.name end, function(k)
    err(ctx, sc.base, k.line, k.col, "fault '%s' is named twice in 'restart on'", k.name)
  end)
  for _, k in ipairs(cl.kinds) do
    if not is_in(M.fault_kinds, k.name) then
      err(ctx, sc.base, k.line, k.col, "unknown fault '%s' in 'restart on'%s", k.name,
          guess_text(k.name, M.fault_kinds) or sformat(" (faults: %s)", concat(M.fault_kinds, ", ")))
    end
  end
end
function SUPERVISION_CLAUSE.standby(ctx, p, sc, cl)
  local inst = p.instances[cl.instance]
  if not inst then
    unknown_instance(ctx, p, sc, sc.base, cl.instance_line, cl.instance_col, cl.instance, "in 'standby'")
  elseif ctx.defs[inst.type] then
    err(ctx, sc.base, cl.instance_line, cl.instance_col, "'%s' is a group (%s): its standby hosts go in its own "
        .. "'host { primary, standby... }'", cl.instance, inst.type)
  end
  for _, a in ipairs(cl.hosts) do host_arg(ctx, p, sc, a, sformat("a standby host of '%s'", cl.instance)) end
end

-- fence T [UNIT] [margin T [UNIT]]: known units, times within FENCE_RANGE (docs/supervision.md, "Fencing").
M.FENCE_RANGE = { fence = { 0.2, 3600 }, margin = { 0.05, 3600 } }
local function fence_time(ctx, sc, what, v, unit, line, col, uline, ucol)
  if unit and not M.units[unit] then
    err(ctx, sc.base, uline, ucol, "unknown unit '%s' of the %s (write s or ms)%s", unit, what,
        guess_text(unit, { "s", "ms" }) or "")
    return
  end
  local s, r = v * M.units[unit or "s"], M.FENCE_RANGE[what]
  if not (s >= r[1] and s <= r[2]) then
    err(ctx, sc.base, line, col, "the %s must be from %g s to %g s, not %s%s", what, r[1], r[2], tostring(v),
        unit and " " .. unit or " s")
  end
end
function SUPERVISION_CLAUSE.fence(ctx, p, sc, cl)
  fence_time(ctx, sc, "fence", cl.within, cl.unit, cl.within_line, cl.within_col, cl.unit_line, cl.unit_col)
  if cl.margin then
    fence_time(ctx, sc, "margin", cl.margin, cl.margin_unit, cl.margin_line, cl.margin_col, cl.margin_unit_line,
               cl.margin_unit_col)
  end
end

local function supervision(ctx, p, sc)
  if not p.supervision then return end
  each_repeat(p.supervision.clauses, function(cl) return cl.kw == "standby" and "standby " .. cl.instance or cl.kw end,
    function(cl, first)
      err(ctx, sc.base, cl.line, cl.col, "'%s%s' is given twice in supervision (first at line %d)", cl.kw,
          cl.kw == "standby" and " " .. cl.instance or "", first.line)
    end)
  for _, cl in ipairs(p.supervision.clauses) do SUPERVISION_CLAUSE[cl.kw](ctx, p, sc, cl) end
end

-- ---------------------------------------------------------------------------------------- the rt section
-- rt { priority N; cpu N; } (docs/time.md, "Real time"): SCHED_FIFO 1..99 and a CPU number, each given once.
local RT_RANGE = { priority = { 1, 99, "1..99 (SCHED_FIFO)" }, cpu = { 0, 1023, "a CPU number, 0..1023" } }

local function rt_section(ctx, p, sc)
  if not p.rt then return end
  each_repeat(p.rt.clauses, function(cl) return cl.kw end, function(cl, first)
    err(ctx, sc.base, cl.line, cl.col, "'%s' is given twice in rt (first at line %d)", cl.kw, first.line)
  end)
  for _, cl in ipairs(p.rt.clauses) do
    local r, v = RT_RANGE[cl.kw], cl.value
    if math.type(v) ~= "integer" or v < r[1] or v > r[2] then
      err(ctx, sc.base, cl.value_line, cl.value_col, "rt %s must be %s, got %s", cl.kw, r[3], tostring(v))
    end
  end
end

local function instances(ctx, p, sc)
  for _, inst in ipairs(p.instances) do
    local path = sc.base .. "." .. inst.name
    local first = sc.first[inst.name]
    if first ~= inst then
      err(ctx, path, inst.line, inst.col, "duplicate instance '%s' in process '%s' (first at line %d)", inst.name,
          p.name, first.line)
    end
    for _, a in ipairs(inst.args) do check_param_arg(ctx, p, sc, a, path) end
    local d = ctx.defs[inst.type]
    if d and #inst.args ~= #d.params then
      err(ctx, path, inst.type_line, inst.type_col, "%s takes %s (%s); instance '%s' gives %d", inst.type,
          plural(#d.params, "argument"), concat(names_of(d.params), ", "), inst.name, #inst.args)
    end
  end
end

--- The leaves: a known type, a host first, then the parameters the manifest asks for.
local function leaves(ctx, p, sc)
  for _, inst in ipairs(p.instances) do
    if not ctx.defs[inst.type] then
      local path, m = sc.base .. "." .. inst.name, ctx.manifest(inst.type)
      local home = ctx.opts.elsewhere and ctx.opts.elsewhere[inst.type]
      local several = ctx.opts.ambiguous and ctx.opts.ambiguous[inst.type]
      if not m and several then
        local choices = {}
        for i, pk in ipairs(several) do choices[i] = pk .. "." .. inst.type end
        err(ctx, path, inst.type_line, inst.type_col, "type '%s' is defined by packages %s: write %s", inst.type,
            concat(several, " and "), concat(choices, " or "))
      elseif not m and home then
        err(ctx, path, inst.type_line, inst.type_col,
            "unknown process type '%s': package '%s' defines it (add 'use %s;' at the top of the file)", inst.type,
            home, home)
      elseif not m and ctx.registry_known then
        local unused = ctx.opts.unused_packages or {}
        err(ctx, path, inst.type_line, inst.type_col, "unknown process type '%s'%s", inst.type,
            guess_text(inst.type, ctx.known_types) or
            " (not defined in this file, not built in, not in a package the file uses" ..
            (#unused > 0 and "; packages it could use: " .. concat(unused, ", ") or "") .. ")")
      end
      local h = inst.args[1]
      if not h then
        err(ctx, path, inst.line, inst.col, "leaf '%s' (%s) has no host: its first argument names the host it runs on",
            inst.name, inst.type)
      elseif h.kind == "number" then
        err(ctx, path, h.line, h.col, "the host of leaf '%s' must be a parameter or a string, not a number", inst.name)
      end
      if h and m then M.leaf_parameters(ctx, path, inst, m) end
    end
  end
end

--- Whether number v is within a manifest parameter's range (its min, max: inclusive; above: exclusive).
function M.in_range(prm, v)
  return not (prm.min and v < prm.min) and not (prm.max and v > prm.max) and not (prm.above and v <= prm.above)
end

--- With `v`: whether `allowed` holds it. Without: "a, b or c".
function M.one_of(allowed, v)
  if v ~= nil then
    for _, a in ipairs(allowed) do if a == v then return true end end
    return false
  end
  if #allowed == 1 then return allowed[1] end
  return concat(allowed, ", ", 1, #allowed - 1) .. " or " .. allowed[#allowed]
end

--- The range of parameter counts a manifest accepts, and the parameters as shown in messages.
local function parameter_range(ps)
  local min, max, shown = 0, #ps, {}
  for i, prm in ipairs(ps) do
    if prm.variadic then
      max = math.huge
      shown[i] = prm.name .. "..."
    elseif prm.required == false then
      shown[i] = prm.name .. (prm.default and prm.default ~= "" and ("=" .. tostring(prm.default)) or "")
    else
      min = i
      shown[i] = prm.name
    end
  end
  return min, max, shown
end

--- A leaf's parameters (its arguments after the host) against its manifest: how many, and their types.
function M.leaf_parameters(ctx, path, inst, m)
  local ps, given = m.params or {}, #inst.args - 1
  local min, max, shown = parameter_range(ps)
  if given < min or given > max then
    local range = min == max and plural(min, "parameter")
      or max == math.huge and sformat("at least %s", plural(min, "parameter"))
      or sformat("%d to %d parameters", min, max)
    err(ctx, path, inst.type_line, inst.type_col, "%s takes the host and %s (%s); instance '%s' has %s", inst.type,
        range, listing(shown), inst.name, plural(given, "parameter"))
  end
  for i = 2, #inst.args do
    local prm = ps[i - 1] or (#ps > 0 and ps[#ps].variadic and ps[#ps]) or nil
    local a = inst.args[i]
    if prm and (prm.type == "number" or prm.type == "integer") and a.kind == "string" then
      err(ctx, path, a.line, a.col, "parameter '%s' of %s is a number, got the string \"%s\"", prm.name, inst.type,
          a.value)
    elseif prm and prm.type == "integer" and a.kind == "number" and math.type(a.value) ~= "integer" then
      err(ctx, path, a.line, a.col, "parameter '%s' of %s is an integer, got %s", prm.name, inst.type,
          tostring(a.value))
    elseif prm and a.kind == "number" and not M.in_range(prm, a.value) then
      err(ctx, path, a.line, a.col, "parameter '%s' of %s must be %s, got %s", prm.name, inst.type,
          prm.range or "in range", tostring(a.value))
    elseif prm and a.kind == "string" and prm.allowed and #prm.allowed > 0 and not M.one_of(prm.allowed, a.value) then
      err(ctx, path, a.line, a.col, "parameter '%s' of %s must be %s, got '%s'", prm.name, inst.type,
          M.one_of(prm.allowed), a.value)
    end
  end
end

--- "no output 'X' on inst (Type); outputs are: ..." (or its external_io, for a group).
local function no_port(ctx, path, line, col, what, port, iname, ty, valid, list)
  if valid.exports then
    return err(ctx, path, line, col, "no %s '%s' on %s (%s); its external_io: %s", what, port, iname, ty,
               listing(valid.exports))
  end
  if not list then
    return err(ctx, path, line, col, "no port '%s' on %s (%s); inputs are: %s; outputs are: %s", port, iname, ty,
               listing(valid.inputs), listing(valid.outputs))
  end
  err(ctx, path, line, col, "no %s '%s' on %s (%s); %ss are: %s", what, port, iname, ty, what, listing(list))
end

local function external_io(ctx, p, sc)
  each_repeat(p.external_io, function(x) return x.alias end, function(x, first)
    err(ctx, sc.base, x.line, x.col, "external port '%s' is declared twice (first at line %d)", x.alias, first.line)
  end)
  for _, x in ipairs(p.external_io) do
    local inst = p.instances[x.instance]
    if not inst then
      unknown_instance(ctx, p, sc, sc.base, x.instance_line, x.instance_col, x.instance, "in external_io")
    else
      local dir, valid = port_info(ctx, p, x.instance, x.port)
      if not dir then
        no_port(ctx, sc.base .. "." .. x.instance, x.port_line, x.port_col, "port", x.port, x.instance, inst.type, valid)
      end
    end
  end
end

local function connection_sets(ctx, p, sc)
  each_repeat(p.internal_connections, function(set) return set.instance .. "\0" .. set.label end, function(set, first)
    err(ctx, sc.base, set.line, set.col, "internal_connections(%s, %s) is defined twice (first at line %d)",
        set.instance, set.label, first.line)
  end)
  for _, set in ipairs(p.internal_connections) do
    if not p.instances[set.instance] then
      unknown_instance(ctx, p, sc, sc.base, set.instance_line, set.instance_col, set.instance, "in internal_connections")
    end
  end
end

--- One end of a connection: the port exists on the instance and goes the way the connection needs.
local function connection_end(ctx, p, sc, iname, port, line, col, want)
  local inst = p.instances[iname]
  local dir, valid = port_info(ctx, p, iname, port, 0, want)
  local path, other = sc.base .. "." .. iname, want == "input" and "output" or "input"
  if not dir then
    no_port(ctx, path, line, col, want, port, iname, inst.type, valid, valid.exports or valid[want .. "s"])
  elseif dir == other then
    err(ctx, path, line, col, "'%s' is an %s of %s (%s): a connection goes from an output to an input", port, other,
        iname, inst.type)
  end
end

local function connections(ctx, p, sc)
  for _, set in ipairs(p.internal_connections) do
    for _, cn in ipairs(set.connections) do
      local ok_from, ok_to = p.instances[cn.from], p.instances[cn.to]
      if not ok_from then unknown_instance(ctx, p, sc, sc.base, cn.line, cn.col, cn.from, "in a connection") end
      if not ok_to then unknown_instance(ctx, p, sc, sc.base, cn.to_line, cn.to_col, cn.to, "in a connection") end
      if p.instances[set.instance] and ok_from and ok_to and cn.from ~= set.instance and cn.to ~= set.instance then
        err(ctx, sc.base .. "." .. set.instance, cn.line, cn.col,
            "connection %s, %s -> %s, %s does not involve %s: a connection set of %s connects its ports",
            cn.from, cn.out, cn.to, cn["in"], set.instance, set.instance)
      end
      if ok_from then connection_end(ctx, p, sc, cn.from, cn.out, cn.out_line, cn.out_col, "output") end
      if ok_to then connection_end(ctx, p, sc, cn.to, cn["in"], cn.in_line, cn.in_col, "input") end
    end
  end
end

--- internal_event_actions: present, well-formed, naming instances and labels that have connection sets.
local function actions(ctx, p, sc)
  local act = p.actions
  if not act then
    return err(ctx, sc.base, p.line, p.col, "process '%s' has no internal_event_actions: nothing of it would ever run",
               p.name)
  end
  if act.error then return err(ctx, sc.base, act.error.line, act.error.col, "in internal_event_actions: %s", act.error.msg) end
  for _, leaf in ipairs(act.expr.leaves) do
    if not p.instances[leaf.name] then
      unknown_instance(ctx, p, sc, sc.base, leaf.line, leaf.col, leaf.name, "in internal_event_actions")
    elseif leaf.label and not sc.sets[leaf.name .. "\0" .. leaf.label] then
      err(ctx, sc.base .. "." .. leaf.name, leaf.line, leaf.col, "label '%s' of '%s' has no internal_connections(%s, %s)",
          leaf.label, leaf.name, leaf.name, leaf.label)
    end
  end
end

-- ------------------------------------------------------------------------------ strings that cannot be used
-- A process's host name and string arguments reach the daemon, the exec of the process and its command line
-- as they are: a control character (a NUL, a line break...) cannot travel there, and a host must be a
-- plausible host name. Each error points at the offending character inside the string.

--- Why s is not a plausible host name (nil when it is one): 1 to 253 bytes, dot-separated labels of 1 to 63
--- letters, digits, '-' and '_', no label starting or ending with '-'. --> reason, the index in s of the
--- offending character (nil when the whole name is at fault)
function M.host_name_problem(s)
  local bad = s:find("[^%w_%.%-]")
  if bad then return sformat("'%s' is not a letter, a digit, '.', '-' or '_'", s:sub(bad, bad)), bad end
  if #s == 0 or #s > 253 then return "a host name has 1 to 253 characters" end
  local at = 1
  for label in (s .. "."):gmatch("([^.]*)%.") do
    if #label == 0 or #label > 63 then return "each dot-separated part has 1 to 63 characters", at end
    if label:find("^%-") then return "a part starts with '-'", at end
    if label:find("%-$") then return "a part ends with '-'", at + #label - 1 end
    at = at + #label + 1
  end
end

--- The column of the i-th character of the string argument a: its escapes (\" \\ \n \t) take two bytes.
local function char_col(ctx, a, i)
  local src, starts = ctx.ast.source, ctx.ast.index and ctx.ast.index.starts
  local quote = starts and starts[a.line] and starts[a.line] + a.col - 1
  if type(src) ~= "string" or not quote or src:sub(quote, quote) ~= '"' then return a.col end
  local pos = quote + 1
  for _ = 1, i - 1 do pos = pos + (src:sub(pos, pos) == "\\" and 2 or 1) end
  return a.col + pos - quote
end

--- A string argument a (described by what) that cannot be used: a control character; for a host, not a
--- plausible host name.
local function usable_string(ctx, path, a, what, is_host)
  if a.kind ~= "string" then return end
  local c = a.value:find("%c")
  if c then
    local b = a.value:byte(c)
    err(ctx, path, a.line, char_col(ctx, a, c), "%s holds a control character (byte \\%d%s), which cannot be "
        .. "passed on", what, b, b == 0 and ", a NUL" or "")
  elseif is_host then
    local why, at = M.host_name_problem(a.value)
    if why then
      err(ctx, path, a.line, at and char_col(ctx, a, at) or a.col, "%s %q is not a host name: %s", what, a.value, why)
    end
  end
end

--- The host of each process definition and the string arguments of its instances (a leaf's first is its host).
local function usable_strings(ctx, p, sc)
  if p.host then usable_string(ctx, sc.base, p.host, sformat("the host of process '%s'", p.name), true) end
  for _, a in ipairs(p.standby_hosts or {}) do
    usable_string(ctx, sc.base, a, sformat("a standby host of process '%s'", p.name), true)
  end
  for _, cl in ipairs(p.supervision and p.supervision.clauses or {}) do
    for _, a in ipairs(cl.hosts or {}) do
      usable_string(ctx, sc.base, a, sformat("a standby host of '%s'", cl.instance), true)
    end
  end
  for _, inst in ipairs(p.instances) do
    local path, leaf = sc.base .. "." .. inst.name, not ctx.defs[inst.type]
    for i, a in ipairs(inst.args) do
      local host = leaf and i == 1
      usable_string(ctx, path, a, host and sformat("the host of leaf '%s'", inst.name)
        or sformat("argument %d of '%s'", i, inst.name), host)
    end
  end
end

--- The templates (`name instances of Type(args) on { hosts };`): a name no instance has, a known type taking
--- the host of each instance first and then the written arguments, hosts that are parameters or strings.
local function templates(ctx, p, sc)
  for _, t in ipairs(p.templates or {}) do
    local path = sc.base .. "." .. t.name
    local clash = p.instances[t.name] or (p.templates[t.name] ~= t and p.templates[t.name])
    if clash then
      err(ctx, path, t.line, t.col, "duplicate instance '%s' in process '%s' (first at line %d)", t.name, p.name,
          clash.line)
    end
    for _, a in ipairs(t.args) do check_param_arg(ctx, p, sc, a, path) end
    for _, a in ipairs(t.hosts) do
      host_arg(ctx, p, sc, a, sformat("a host of template '%s'", t.name))
      usable_string(ctx, path, a, sformat("a host of template '%s'", t.name), true)
    end
    local d, m = ctx.defs[t.type], ctx.manifest(t.type)
    if d and #t.args + 1 ~= #d.params then
      err(ctx, path, t.type_line, t.type_col, "%s takes %s (%s): each instance's host, then %s; template '%s' gives %d",
          t.type, plural(#d.params, "argument"), concat(names_of(d.params), ", "),
          plural(math.max(#d.params - 1, 0), "written argument"), t.name, #t.args)
    elseif not d and m then
      -- as a leaf: the host given when an instance is added, then the written parameters
      local inst = { name = t.name, type = t.type, type_line = t.type_line, type_col = t.type_col,
                     args = { t.hosts[1] } }
      for i, a in ipairs(t.args) do inst.args[i + 1] = a end
      M.leaf_parameters(ctx, path, inst, m)
    elseif not d and ctx.registry_known then
      err(ctx, path, t.type_line, t.type_col, "unknown process type '%s'%s", t.type,
          guess_text(t.type, ctx.known_types) or "")
    end
  end
end

--- The verify { } section: its properties parse and name the process's instances (dca.verify.props), so a plain
--- `dca check` reports them; `--verify` checks what they say.
local function verify_section(ctx, p, sc)
  if not p.verify then return end
  local own = {}
  for _, q in ipairs(ctx.ast.processes) do
    for _, inst in ipairs(q.instances) do
      if inst.type == p.name then own[inst.name] = true end
    end
  end
  local _, errors = props.of_process(p, own)
  for _, e in ipairs(errors) do
    local line, col = ctx.ast.index:at(e.pos)
    err(ctx, sc.base, line, col, "%s", e.msg)
  end
end

-- -------------------------------------------------------------------------------------------- the pipeline

--- A pass run for each process definition p, with its scope sc: fn(ctx, p, sc).
local function each(fn)
  return function(ctx)
    for _, p in ipairs(ctx.ast.processes) do fn(ctx, p, ctx.scope[p]) end
  end
end

--- The passes, in order, each a function(ctx); a new check is one more entry.
M.passes = {
  known_types, instance_paths, duplicate_definitions, scopes, uses,        -- the context, the packages
  each(parameters), each(process_host), each(instances), each(leaves),     -- each process definition
  each(external_io), each(connection_sets), each(connections), each(actions), each(usable_strings),
  each(supervision), each(rt_section),                                     -- its supervision policy, real time
  each(templates),                                                         -- its templates (a fleet)
  each(verify_section),                                                    -- its properties' names
  recursion,                                                               -- between process types
}

local function by_position(a, b)
  if a.line ~= b.line then return a.line < b.line end
  if a.col ~= b.col then return a.col < b.col end
  return a.msg < b.msg
end

--- Runs every pass; returns the list of errors in file order (empty when the file is correct).
function M.check(ast, opts)
  local ctx = { ast = ast, defs = ast.by_name, opts = opts or {}, errors = {} }
  for _, pass in ipairs(M.passes) do pass(ctx) end
  sort(ctx.errors, by_position)
  return ctx.errors
end

-- ------------------------------------------------------------------------------ config("key") parameters

--- Whether a default fits the type of the manifest parameter it is for.
local function default_fits(pm, v)
  if pm.type == "integer" then return math.type(v) == "integer" end
  if pm.type == "number" or pm.type == "string" or pm.type == "boolean" then return type(v) == pm.type end
  return true
end

--- The i-th argument `a` of inst (in process p), a config("key"), against the defaults d.
local function config_arg(out, ast, p, inst, i, a, d, manifest)
  local pm = manifest and manifest.params and manifest.params[i - 1]  -- the first argument is the host
  local at = sformat("%s:%d:%d: ", ast.file, a.line or 0, a.col or 0)
  local what = sformat("%s.%s parameter %d%s", p.name, inst.name, i - 1, pm and pm.name and (" '" .. pm.name .. "'") or "")
  local v = d.values[a.value]
  if v == nil then
    local guess = source.closest(a.value, d.keys)
    out.warnings[#out.warnings + 1] = sformat("%swarning: %s: config key '%s' is not in %s%s", at, what, a.value,
      d.path, guess and sformat(" (did you mean %s?)", guess) or " (the repository must hold it when the system starts)")
  elseif pm and not default_fits(pm, v) then
    out.errors[#out.errors + 1] = sformat("%s%s: config key '%s' defaults to %s in %s, not %s", at, what, a.value,
      type(v) == "string" and sformat("%q", v) or tostring(v), d.path,
      pm.type == "integer" and "an integer" or ("a " .. pm.type))
  end
end

--- The config("key") parameters of ast against a defaults file (the list dca.config.read_file gives, read from
--- path): { warnings = {...}, errors = {...} }, each a "FILE:LINE:COL: ..." line. A key the defaults lack is a
--- warning (the repository may hold it); a default of the wrong type for the parameter is an error.
--- registry: the controller manifests (parameter names and types), or nil.
function M.config_keys(ast, defaults, path, registry)
  local out, d = { warnings = {}, errors = {} }, { values = {}, keys = {}, path = path }
  for _, e in ipairs(defaults) do d.values[e.key], d.keys[#d.keys + 1] = e.value, e.key end
  for _, p in ipairs(ast.processes) do
    for _, inst in ipairs(p.instances) do
      for i, a in ipairs(inst.args or {}) do
        if a.kind == "config" then config_arg(out, ast, p, inst, i, a, d, registry and registry[inst.type]) end
      end
    end
  end
  return out
end

--- "file:line:col: path: message", the source line and a caret.
function M.format(ast, e)
  return source.format(ast.file, ast.index, e.line, e.col, (e.path and (e.path .. ": ") or "") .. e.msg)
end

--- All errors formatted, separated by newlines, with a closing count line.
function M.format_all(ast, errors)
  local out = {}
  for i, e in ipairs(errors) do out[i] = M.format(ast, e) end
  out[#out + 1] = sformat("%s: %s", ast.file, plural(#errors, "error"))
  return concat(out, "\n")
end

return M
