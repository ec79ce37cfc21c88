-- dca.lang.ports: the types of ports, which output can feed which input, and the sizes a check can work out
-- before anything runs (docs/lua.md, "Port types"). Pure Lua: the manifests come from the caller.
--
--   ports.shape(spec)        --> { kind = "scalar" | "vector" | "vectorx" | "value" | "message", size = n | nil,
--                                message = "geometry_msgs/msg/Twist" | nil } | nil
--                                (a manifest port {type=, size=, message=}; nil when the manifest gives no type)
--   ports.text(shape)        --> "scalar", "vector[3]", "vectorx", "vectorx of size 3", "value",
--                                "geometry_msgs/msg/Twist"
--   ports.fits(out, in)      --> true | false, why ("" or ": ..." to end a message with)
--   ports.check(tree, world) --> { { line, col, msg }, ... }: every connection of the instance tree
--                                (dca.lang.model) and every device port against `world`, the robot process's
--                                signals { outputs = { [name] = spec }, inputs = { [name] = spec } } or nil
--   ports.device_signal(device, params, args) --> signal | false | nil, why: a device signal with the leaf's
--                                arguments put in for its {param}s and {param[i]}s (the check's and the
--                                wiring's one expansion); false: no i-th word, the port is left unwired
--
-- A scalar is one double, a vector[n] n of them, a vectorx any number, a value a msgpack value, a message one ROS 2
-- message of its type (docs/data-plane.md, "Typed messages"). An output feeds an input when both are values, both
-- messages of the same type, or both numeric and the input is a vectorx (it takes any size) or the two
-- sizes are equal (so a scalar and a vector[1] meet). A vectorx output's size is known to the check only for
-- the built-ins below; any other vectorx output feeds vectorx inputs only.
local M = {}

local ipairs, type, tostring, sformat = ipairs, type, tostring, string.format

--- How the built-ins' vectorx outputs take their size (controllers/builtins.h): Constant writes one element
--- per value of its parameter `values`; Gain and Sum write as many as they are fed (on In, on In1 and In2).
M.sizes = {
  Constant = { Out = { values = "values" } },
  Gain = { Out = { inputs = { "In" } } },
  Sum = { Out = { inputs = { "In1", "In2" } } },
}

function M.shape(spec)
  local t = spec and spec.type
  if t == "scalar" then return { kind = "scalar", size = 1 } end
  if t == "vector" then return { kind = "vector", size = spec.size } end
  if t == "vectorx" or t == "value" then return { kind = t } end
  if t == "message" then return { kind = t, message = spec.message } end
  return nil
end

function M.text(s)
  if s.kind == "vector" then return sformat("vector[%s]", tostring(s.size)) end
  if s.kind == "message" then return tostring(s.message) end
  if s.kind == "vectorx" and s.size then return sformat("vectorx of size %d", s.size) end
  return s.kind
end

function M.fits(out, inp)
  if out.kind == "message" or inp.kind == "message" then
    return out.kind == inp.kind and out.message == inp.message, ""
  end
  if out.kind == "value" or inp.kind == "value" then return out.kind == inp.kind, "" end
  if inp.kind == "vectorx" or out.size == inp.size then return true end
  if not out.size then return false, ": dca check cannot tell how many values it writes" end
  return false, ""
end

--- A device signal named after the leaf's arguments (docs/robots.md): "joint.{joint}.position" takes the
--- argument of parameter `joint`, or its default; "joint.{joints[2]}.position" takes the second word of it (words
--- are separated by spaces or commas). `params` are the manifest's, `args` the leaf's arguments after its host, in
--- the same order. --> the signal | false (no such word: the port is no device port of this leaf, left unwired)
--- | nil, why (a parameter the leaf lacks, or an argument that is no literal string or number: config("key") is
--- read only at the start)
function M.device_signal(device, params, args)
  local err, absent
  local function argument(name)
    for i, pm in ipairs(params or {}) do
      if pm.name == name then
        local v = args and args[i]
        if v == nil then v = pm.default end
        if type(v) == "string" or type(v) == "number" then return tostring(v) end
        err = err or sformat("its device signal %s needs a literal argument '%s'", device, name)
        return ""
      end
    end
    err = err or sformat("its device signal %s names no parameter '%s'", device, name)
    return ""
  end
  local signal = device:gsub("{([%w_]+)%[(%d+)%]}", function(name, n)
    local k, word = 0, nil
    for w in argument(name):gmatch("[^%s,]+") do
      k = k + 1
      if k == tonumber(n) then word = w break end
    end
    absent = absent or word == nil
    return word or ""
  end):gsub("{([%w_]+)}", argument)
  if err then return nil, err end
  if absent then return false end
  return signal
end

local function find_port(list, name)
  for _, p in ipairs(list or {}) do
    if p.name == name then return p end
  end
end

-- --------------------------------------------------------------------------------------- the instance tree

--- Every connection of the tree resolved to leaf ports (dca.lang.model.connections) and the connections into
--- each leaf input: links, feeders[leaf path .. "\0" .. input] = { link, ... }.
local function links_of(tree)
  local links, feeders = require("dca.lang.model").connections(tree) or {}, {}
  for _, l in ipairs(links) do
    local key = l.to.path .. "\0" .. l["in"]
    feeders[key] = feeders[key] or {}
    feeders[key][#feeders[key] + 1] = l
  end
  return links, feeders
end

--- The shapes of leaf outputs, the sizes of the built-ins' vectorx outputs worked out from their parameters and
--- from what feeds them (a cycle, or feeders of differing or unknown sizes, leave the size unknown).
local function output_shapes(feeders)
  local memo, busy = {}, {}
  local out_shape
  -- The one size every output feeding input `name` of `leaf` writes, or nil.
  local function fed_size(leaf, name)
    local size
    for _, l in ipairs(feeders[leaf.path .. "\0" .. name] or {}) do
      local s = out_shape(l.from, l.out)
      if not s or not s.size or (size and size ~= s.size) then return nil end
      size = s.size
    end
    return size
  end
  local function sized(leaf, port, s)
    local m = leaf.manifest
    local rule = s.kind == "vectorx" and not m.package and M.sizes[leaf.type] and M.sizes[leaf.type][port]
    if not rule then return s end
    if rule.values then
      for i, prm in ipairs(m.params or {}) do
        if prm.name == rule.values then return { kind = s.kind, size = math.max(#leaf.params - i + 1, 0) } end
      end
      return s
    end
    local size
    for _, name in ipairs(rule.inputs) do
      local n = fed_size(leaf, name)
      if not n or (size and size ~= n) then return s end
      size = n
    end
    return { kind = s.kind, size = size }
  end
  function out_shape(leaf, port)
    local key = leaf.path .. "\0" .. port
    if memo[key] ~= nil or busy[key] then return memo[key] or nil end
    local s = leaf.manifest and M.shape(find_port(leaf.manifest.outputs, port))
    if s then
      busy[key] = true
      s = sized(leaf, port, s)
      busy[key] = nil
    end
    memo[key] = s or false
    return s
  end
  return out_shape
end

-- "main.chain.src.Out (vectorx of size 1, main.chain.src.count.Count)": an end as the connection names it, its
-- type, and the leaf port behind it when that is elsewhere.
local function named(n, inst, port, leaf, leaf_port, s)
  local as_written = sformat("%s.%s.%s", n.path, inst, port)
  local behind = sformat("%s.%s", leaf.path, leaf_port)
  if behind == as_written then return sformat("%s (%s)", as_written, M.text(s)) end
  return sformat("%s (%s, %s)", as_written, M.text(s), behind)
end

local function connection_errors(links, out_shape, errors)
  for _, l in ipairs(links) do
    local o = out_shape(l.from, l.out)
    local i = l.to.manifest and M.shape(find_port(l.to.manifest.inputs, l["in"]))
    if o and i then
      local ok, why = M.fits(o, i)
      if not ok then
        local c = l.written
        errors[#errors + 1] = { line = c.line, col = c.col, key = "", msg = sformat("%s cannot feed %s%s",
          named(l.group, c.from, c.out, l.from, l.out, o), named(l.group, c.to, c["in"], l.to, l["in"], i), why) }
      end
    end
  end
end

-- The device ports of `leaf` against the world's signals: an input is fed by the world's output of its
-- signal, an output feeds the world's input. A signal named after the leaf's arguments is expanded first.
local function device_errors(leaf, world, errors)
  for _, dir in ipairs({ "inputs", "outputs" }) do
    local signals = dir == "inputs" and world.outputs or world.inputs
    for _, p in ipairs(leaf.manifest[dir] or {}) do
      local function report(fmt, ...)
        errors[#errors + 1] = { line = leaf.line, col = leaf.col, key = dir .. p.name, msg = sformat(fmt, ...) }
      end
      local port = M.shape(p)
      if p.device and p.device ~= "" and port then
        local mine = sformat("%s.%s (%s, device port of %s)", leaf.path, p.name, M.text(port), leaf.type)
        local name, why = M.device_signal(p.device, leaf.manifest.params, leaf.params)
        local sig = name and signals[name]
        if name == false then  -- an unused slot ({joints[7]} of six joints): no device port, nothing to check
        elseif not name then
          report("%s: %s", mine, why)
        elseif not sig then
          report("%s: the world has no %s '%s'", mine, dir == "inputs" and "sensor" or "command", name)
        else
          local theirs = sformat("world.%s (%s)", name, M.text(M.shape(sig)))
          local o, i = M.shape(sig), port
          if dir == "outputs" then o, i = port, M.shape(sig) end
          local ok, fit = M.fits(o, i)
          if not ok and dir == "inputs" then report("%s cannot feed %s%s", theirs, mine, fit) end
          if not ok and dir == "outputs" then report("%s cannot feed %s%s", mine, theirs, fit) end
        end
      end
    end
  end
end

--- The type errors of the instance tree: its connections (through external_io to the leaf ports) and, with
--- `world`, its leaves' device ports. One error per position (a process instantiated twice is reported once).
function M.check(tree, world)
  local links, feeders = links_of(tree)
  local errors = {}
  connection_errors(links, output_shapes(feeders), errors)
  if world then
    require("dca.lang.model").walk(tree, function(n)
      if n.kind == "leaf" and n.manifest then device_errors(n, world, errors) end
    end)
  end
  local seen, out = {}, {}
  for _, e in ipairs(errors) do
    local key = e.line .. ":" .. e.col .. ":" .. e.key
    if not seen[key] then
      seen[key] = true
      out[#out + 1] = { line = e.line, col = e.col, msg = e.msg }
    end
  end
  table.sort(out, function(a, b)
    if a.line ~= b.line then return a.line < b.line end
    if a.col ~= b.col then return a.col < b.col end
    return a.msg < b.msg
  end)
  return out
end

return M
