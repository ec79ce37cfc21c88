-- dca.lang.check: static checks over a parsed DCA file (dca.lang.parser), every error at once.
--
--   local errors = check.check(ast, {
--     root = "main",              -- the root process (default: "main" when the file has one)
--     types = core.types(),       -- optional registry: { [Type] = { inputs = {{name=}...}, outputs = ..., params = ... } }
--     manifest = function(type) end,  -- optional instead of `types`: a manifest or nil
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

local M = {}

local sformat, concat, sort = string.format, table.concat, table.sort
local ipairs, pairs, type, tostring = ipairs, pairs, type, tostring

--- Manifests of the built-in leaf types.
M.builtins = {
  Timer = { inputs = {}, outputs = {}, params = { { name = "duration", type = "number" } }, builtin = true },
  Deadline = { inputs = {}, outputs = {}, params = { { name = "duration", type = "number" } }, builtin = true },
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

--- Runs every static check; returns the list of errors (empty when the file is correct).
function M.check(ast, opts)
  opts = opts or {}
  local errors = {}
  local defs = ast.by_name
  local registry = opts.types
  local manifest_fn = opts.manifest
  local registry_known = registry ~= nil or manifest_fn ~= nil
  local function manifest(t)
    if registry and registry[t] then return registry[t] end
    if manifest_fn then
      local m = manifest_fn(t)
      if m then return m end
    end
    return M.builtins[t]
  end
  -- every type name anyone knows, for "did you mean"
  local known_types = {}
  for _, p in ipairs(ast.processes) do known_types[#known_types + 1] = p.name end
  for t in pairs(M.builtins) do known_types[#known_types + 1] = t end
  if registry then for t in pairs(registry) do known_types[#known_types + 1] = t end end
  for _, t in ipairs(opts.type_names or {}) do known_types[#known_types + 1] = t end
  sort(known_types)

  -- paths: the first instance path of each process definition, from the root
  local root_name = opts.root
  if not root_name and defs.main then root_name = "main" end
  local path_of = {}
  if root_name then
    local root = defs[root_name]
    if root then
      path_of[root] = root_name
      local queue, qi = { root }, 1
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
    else
      local msg = sformat("no process '%s' to run as the root", root_name)
      local guess = source.closest(root_name, names_of(ast.processes))
      if guess then msg = msg .. sformat(" (did you mean '%s'?)", guess) end
      errors[#errors + 1] = { line = 1, col = 1, path = root_name, msg = msg }
    end
  end

  local function err(path, line, col, fmt, ...)
    errors[#errors + 1] = { line = line, col = col, path = path, msg = sformat(fmt, ...) }
  end

  local port_info
  -- The export names of group `d`, without those known to go the other way than `want` ("input"/"output").
  local function names_of_exports(d, want, depth)
    local out, seen = {}, {}
    for _, x in ipairs(d.external_io) do
      if not seen[x.alias] then
        seen[x.alias] = true
        local dir = want and port_info(d, x.instance, x.port, depth + 1) or "unknown"
        if dir == "unknown" or dir == want then out[#out + 1] = x.alias end
      end
    end
    return out
  end
  -- Direction of `port` on instance `iname` of process `proc`: "input" | "output" | "unknown" (no manifest)
  -- or nil when the port does not exist; the second result lists the valid names for messages.
  function port_info(proc, iname, port, depth, want)
    depth = depth or 0
    local inst = proc.instances[iname]
    if not inst or depth > 50 then return "unknown" end
    local d = defs[inst.type]
    if d then
      local x = d.external_io[port]
      if not x then return nil, { exports = names_of_exports(d, want, depth) } end
      local dir = port_info(d, x.instance, x.port, depth + 1)
      return dir or "unknown"
    end
    local m = manifest(inst.type)
    if not m then return "unknown" end
    for _, p in ipairs(m.inputs or {}) do if p.name == port then return "input" end end
    for _, p in ipairs(m.outputs or {}) do if p.name == port then return "output" end end
    return nil, { inputs = names_of(m.inputs), outputs = names_of(m.outputs) }
  end

  -- duplicate process definitions
  local first_def = {}
  for _, p in ipairs(ast.processes) do
    if first_def[p.name] then
      err(p.name, p.line, p.col, "process '%s' is defined twice (first at line %d)", p.name, first_def[p.name].line)
    else
      first_def[p.name] = p
    end
  end

  for _, p in ipairs(ast.processes) do
    local base = path_of[p] or p.name
    local function ipath(name) return base .. "." .. name end
    -- parameters
    local params = {}
    for _, prm in ipairs(p.params) do
      if params[prm.name] then
        err(base, prm.line, prm.col, "parameter '%s' is declared twice in process '%s'", prm.name, p.name)
      end
      params[prm.name] = true
    end
    local param_list = names_of(p.params)
    local signature = sformat("%s(%s)", p.name, concat(param_list, ", "))
    local function check_param_arg(a, path)
      if a.kind == "param" and not params[a.value] then
        local guess = source.closest(a.value, param_list)
        err(path, a.line, a.col, "parameter '%s' is not declared: process %s%s", a.value, signature,
            guess and sformat(" (did you mean '%s'?)", guess) or "")
      end
    end
    for _, d in ipairs(p.duplicate_sections) do
      err(base, d.line, d.col, "section '%s' appears twice in process '%s' (first at line %d)", d.section, p.name,
          d.first_line)
    end
    -- host
    if p.host then
      check_param_arg(p.host, base)
      if p.host.kind == "number" then
        err(base, p.host.line, p.host.col, "the host of process '%s' must be a parameter or a string, not a number",
            p.name)
      end
    end
    -- instances
    local seen = {}
    for _, inst in ipairs(p.instances) do
      local path = ipath(inst.name)
      if seen[inst.name] then
        err(path, inst.line, inst.col, "duplicate instance '%s' in process '%s' (first at line %d)", inst.name,
            p.name, seen[inst.name].line)
      else
        seen[inst.name] = inst
      end
      for _, a in ipairs(inst.args) do check_param_arg(a, path) end
      local d = defs[inst.type]
      local nargs = #inst.args
      if d then
        if nargs ~= #d.params then
          err(path, inst.type_line, inst.type_col, "%s takes %s (%s); instance '%s' gives %d",
              inst.type, plural(#d.params, "argument"), concat(names_of(d.params), ", "), inst.name, nargs)
        end
      else
        local m = manifest(inst.type)
        if not m and registry_known then
          local guess = source.closest(inst.type, known_types)
          err(path, inst.type_line, inst.type_col, "unknown process type '%s'%s", inst.type,
              guess and sformat(" (did you mean '%s'?)", guess) or
              " (not defined in this file, not built in, not in the controller registry)")
        end
        if nargs == 0 then
          err(path, inst.line, inst.col, "leaf '%s' (%s) has no host: its first argument names the host it runs on",
              inst.name, inst.type)
        else
          local h = inst.args[1]
          if h.kind == "number" then
            err(path, h.line, h.col, "the host of leaf '%s' must be a parameter or a string, not a number", inst.name)
          end
          if m then
            local ps = m.params or {}
            local min, max = 0, #ps
            local shown = {}
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
            local given = nargs - 1
            if given < min or given > max then
              local range
              if min == max then range = plural(min, "parameter")
              elseif max == math.huge then range = sformat("at least %s", plural(min, "parameter"))
              else range = sformat("%d to %d parameters", min, max) end
              err(path, inst.type_line, inst.type_col, "%s takes the host and %s (%s); instance '%s' has %s",
                  inst.type, range, listing(shown), inst.name, plural(given, "parameter"))
            end
            for i = 2, nargs do
              local prm = ps[i - 1]
              if not prm and #ps > 0 and ps[#ps].variadic then prm = ps[#ps] end
              local a = inst.args[i]
              if prm and (prm.type == "number" or prm.type == "integer") and a.kind == "string" then
                err(path, a.line, a.col, "parameter '%s' of %s is a number, got the string \"%s\"", prm.name,
                    inst.type, a.value)
              elseif prm and prm.type == "integer" and a.kind == "number" and math.type(a.value) ~= "integer" then
                err(path, a.line, a.col, "parameter '%s' of %s is an integer, got %s", prm.name, inst.type,
                    tostring(a.value))
              end
            end
          end
        end
      end
    end
    local inst_names = {}
    for name in pairs(seen) do inst_names[#inst_names + 1] = name end
    sort(inst_names)
    local function unknown_instance(path, line, col, name, where)
      local guess = source.closest(name, inst_names)
      for _, inst in ipairs(p.instances) do
        if inst.type == name then
          return err(path, line, col, "unknown instance '%s' %s: '%s' is the type of instance '%s' (name the instance)",
                     name, where, name, inst.name)
        end
      end
      err(path, line, col, "unknown instance '%s' %s%s", name, where,
          guess and sformat(" (did you mean '%s'?)", guess) or sformat(" (instances: %s)", listing(inst_names)))
    end
    -- external_io
    local aliases = {}
    for _, x in ipairs(p.external_io) do
      if aliases[x.alias] then
        err(base, x.line, x.col, "external port '%s' is declared twice (first at line %d)", x.alias,
            aliases[x.alias].line)
      else
        aliases[x.alias] = x
      end
      if not p.instances[x.instance] then
        unknown_instance(base, x.instance_line, x.instance_col, x.instance, "in external_io")
      else
        local dir, valid = port_info(p, x.instance, x.port)
        if not dir then
          local inst = p.instances[x.instance]
          if valid.exports then
            err(ipath(x.instance), x.port_line, x.port_col, "no port '%s' on %s (%s); its external_io: %s", x.port,
                x.instance, inst.type, listing(valid.exports))
          else
            err(ipath(x.instance), x.port_line, x.port_col, "no port '%s' on %s (%s); inputs are: %s; outputs are: %s", x.port,
                x.instance, inst.type, listing(valid.inputs), listing(valid.outputs))
          end
        end
      end
    end
    -- internal_connections
    local sets = {}
    for _, set in ipairs(p.internal_connections) do
      local key = set.instance .. "\0" .. set.label
      if sets[key] then
        err(base, set.line, set.col, "internal_connections(%s, %s) is defined twice (first at line %d)", set.instance,
            set.label, sets[key].line)
      else
        sets[key] = set
      end
      if not p.instances[set.instance] then
        unknown_instance(base, set.instance_line, set.instance_col, set.instance, "in internal_connections")
      end
      for _, cn in ipairs(set.connections) do
        local ok_from, ok_to = p.instances[cn.from], p.instances[cn.to]
        if not ok_from then unknown_instance(base, cn.line, cn.col, cn.from, "in a connection") end
        if not ok_to then unknown_instance(base, cn.to_line, cn.to_col, cn.to, "in a connection") end
        if p.instances[set.instance] and ok_from and ok_to and cn.from ~= set.instance and cn.to ~= set.instance then
          err(ipath(set.instance), cn.line, cn.col,
              "connection %s, %s -> %s, %s does not involve %s: a connection set of %s connects its ports",
              cn.from, cn.out, cn.to, cn["in"], set.instance, set.instance)
        end
        if ok_from then
          local dir, valid = port_info(p, cn.from, cn.out, 0, "output")
          local ty = ok_from.type
          if not dir then
            if valid.exports then
              err(ipath(cn.from), cn.out_line, cn.out_col, "no output '%s' on %s (%s); its external_io: %s", cn.out, cn.from,
                  ty, listing(valid.exports))
            else
              err(ipath(cn.from), cn.out_line, cn.out_col, "no output '%s' on %s (%s); outputs are: %s", cn.out, cn.from, ty,
                  listing(valid.outputs))
            end
          elseif dir == "input" then
            err(ipath(cn.from), cn.out_line, cn.out_col,
                "'%s' is an input of %s (%s): a connection goes from an output to an input", cn.out, cn.from, ty)
          end
        end
        if ok_to then
          local dir, valid = port_info(p, cn.to, cn["in"], 0, "input")
          local ty = ok_to.type
          if not dir then
            if valid.exports then
              err(ipath(cn.to), cn.in_line, cn.in_col, "no input '%s' on %s (%s); its external_io: %s", cn["in"], cn.to, ty,
                  listing(valid.exports))
            else
              err(ipath(cn.to), cn.in_line, cn.in_col, "no input '%s' on %s (%s); inputs are: %s", cn["in"], cn.to, ty,
                  listing(valid.inputs))
            end
          elseif dir == "output" then
            err(ipath(cn.to), cn.in_line, cn.in_col,
                "'%s' is an output of %s (%s): a connection goes from an output to an input", cn["in"], cn.to, ty)
          end
        end
      end
    end
    -- internal_event_actions
    local act = p.actions
    if not act then
      err(base, p.line, p.col, "process '%s' has no internal_event_actions: nothing of it would ever run", p.name)
    elseif act.error then
      err(base, act.error.line, act.error.col, "in internal_event_actions: %s", act.error.msg)
    else
      for _, leaf in ipairs(act.expr.leaves) do
        if not p.instances[leaf.name] then
          unknown_instance(base, leaf.line, leaf.col, leaf.name, "in internal_event_actions")
        elseif leaf.label and not sets[leaf.name .. "\0" .. leaf.label] then
          err(ipath(leaf.name), leaf.line, leaf.col, "label '%s' of '%s' has no internal_connections(%s, %s)",
              leaf.label, leaf.name, leaf.name, leaf.label)
        end
      end
    end
  end

  -- recursion between process types (each cycle reported once, at the instance that closes it)
  local state = {}   -- nil: unvisited, 1: on the stack, 2: done
  local stack = {}
  local function visit(p)
    state[p] = 1
    stack[#stack + 1] = p
    for _, inst in ipairs(p.instances) do
      local d = defs[inst.type]
      if d then
        if state[d] == 1 then
          local chain, on = {}, false
          for _, q in ipairs(stack) do
            if q == d then on = true end
            if on then chain[#chain + 1] = q.name end
          end
          chain[#chain + 1] = d.name
          err(path_of[p] and (path_of[p] .. "." .. inst.name) or (p.name .. "." .. inst.name), inst.type_line,
              inst.type_col, "recursive process types: %s (a process cannot contain itself)", concat(chain, " -> "))
        elseif not state[d] then
          visit(d)
        end
      end
    end
    stack[#stack] = nil
    state[p] = 2
  end
  for _, p in ipairs(ast.processes) do
    if not state[p] and first_def[p.name] == p then visit(p) end
  end

  sort(errors, function(a, b)
    if a.line ~= b.line then return a.line < b.line end
    if a.col ~= b.col then return a.col < b.col end
    return a.msg < b.msg
  end)
  return errors
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
