-- dca.supervisor.wiring: a group's connections and device ports, made at its start and again after a restart,
-- as functions over the supervisor `sup` (dca.supervisor). Commands reach a leaf through wiring.to_leaf.
--
--   wiring.to_leaf(sup, leaf_path, msg, timeout, cb)  -- to the node of a leaf: directly when it is a child, else
--                                   --   through the child supervisor whose subtree holds it. cb(reply, err)
--   wiring.connect(sup, cb)         -- the group's own connections, created inactive at each source node
--   wiring.devices(sup, cb, only)   -- the device ports of its leaves (of leaf `only`) wired to the world
--   wiring.rewire(sup, path, cb)    -- its connections of the leaf or subtree `path` (started anew) made again
--   wiring.device_ports(spec, types)   --> the device ports of the group's own leaves
--   wiring.check_ports(sup, path, handle, cb)  -- the ports of leaf `path`'s new process (a restart) against
--                                   --   every use of them this group knows (M.ports_mismatch)
--   wiring.is_device_input(sup, leaf, port)  --> whether that port of that leaf is a device input
--   wiring.replayed(sup, src, out) --> whether output src.out is replayed (spec.replay_ports: `dca run
--                                   --   --replay-ports`): its connections start at the world's "replay:PATH"
--   wiring.at_source(sup, src, msg, timeout, cb)  -- a message to a connection's source: the leaf, or the world
--                                   --   for wiring.WORLD (set_sources of a replayed output's sets)
-- cb(true) | cb(nil, the first reason, naming the connection or port).
local M = {}

local async = require "dca.async"
local child = require "dca.supervisor.child"
local port_types = require "dca.lang.ports"
local spec_mod = require "dca.supervisor.spec"
local taps = require "dca.supervisor.taps"

local ipairs, type, tostring, sformat, concat = ipairs, type, tostring, string.format, table.concat

-- Sends a message to the node of leaf `leaf_path`, directly when it is ours, else through the child DCAS
-- whose subtree holds it. cb(reply, err).
function M.to_leaf(sup, leaf_path, msg, timeout, cb)
  local c = spec_mod.route(sup.spec, leaf_path)
  local ch = c and sup.children[c.name]
  if not ch or not ch.handle then
    if cb then cb(nil, sformat("%s: no route to %s", sup.path, leaf_path)) end
    return
  end
  -- always a request: its answer (or its failure, logged) says the command arrived
  cb = cb or function(reply, err)
    local ok, why = async.outcome(reply, err)
    if not ok then sup:log("%s: %s to %s: %s", sup.path, tostring(msg.type), leaf_path, why) end
  end
  timeout = timeout or sup.timeouts.request
  taps.note(ch, leaf_path, msg)
  if ch.kind == "leaf" then
    ch.handle.request(msg, timeout, cb)
  else
    ch.handle.request({ type = "node", leaf = leaf_path, msg = msg }, timeout, cb)
  end
end

--- The source of a set in set_sources that is the world: a replayed output's connections start there.
M.WORLD = "@world"

function M.replayed(sup, src, out)
  local list = sup.spec.replay_ports
  if not list then return false end
  if not sup.replay_set then
    sup.replay_set = {}
    for _, p in ipairs(list) do sup.replay_set[p] = true end
  end
  return sup.replay_set[src .. "." .. out] == true
end

function M.at_source(sup, src, msg, timeout, cb)
  if src ~= M.WORLD then M.to_leaf(sup, src, msg, timeout, cb) return end
  sup.rt.world(msg, timeout or sup.timeouts.request, cb or function(reply, err)
    local ok, why = async.outcome(reply, err)
    if not ok then sup:log("%s: %s to the world: %s", sup.path, tostring(msg.type), why) end
  end)
end

-- (the start protocol, phase 2) This group's own connections, resolved to leaf ports, created inactive at each source node.
function M.connect(sup, cb)
  local wires, errs = spec_mod.wiring(sup.spec)
  if not wires then cb(nil, concat(errs, "; ")) return end
  sup.wires = wires
  sup.set_sources = {}
  for _, w in ipairs(wires) do
    local s = sup.set_sources[w.set]
    if not s then s = {} sup.set_sources[w.set] = s end
    local src = M.replayed(sup, w.src, w.out) and M.WORLD or w.src
    if not s[src] then s[src] = true s[#s + 1] = src end
  end
  M.connect_wires(sup, wires, cb)
end

-- Makes the connections `list` (spec_mod.wiring's) at once; `after(w, k)`, if given, runs once `w` is made and
-- calls k(true) | k(nil, reason). cb(true) once every one is made | cb(nil, the first reason).
function M.connect_wires(sup, list, cb, after)
  local j = async.join(cb, true)
  for _, w in ipairs(list) do
    local k = j.add()
    M.connect_wire(sup, w, function(ok, err)
      if ok and after then after(w, k) else k(ok, err) end
    end)
  end
  j.close()
end

-- One connection `w` (from spec_mod.wiring) made at its source node; a replayed output's at the world, from its
-- recorded samples, the live writer cut from it. cb(true) | cb(nil, reason naming it)
function M.connect_wire(sup, w, cb)
  local replayed = M.replayed(sup, w.src, w.out)
  local msg = { type = "connect", out = replayed and ("replay:" .. w.src .. "." .. w.out) or w.out, to = w.dst,
                ["in"] = w["in"], set = w.set, mode = "push" }
  M.at_source(sup, replayed and M.WORLD or w.src, msg, sup.timeouts.connect, function(reply, err)
    local ok, why = async.outcome(reply, err)
    if ok then cb(true) return end
    cb(nil, sformat("%s: connecting %s%s.%s -> %s.%s (set %s): %s", sup.path, replayed and "the replay of " or "",
      w.src, w.out, w.dst, w["in"], w.set, why))
  end)
end

--- The device ports of the group's own leaves, in declaration order:
--- { { leaf = path, type = T, port = name, signal = "arm.q", dir = "in" | "out", err = why | nil }, ... }
function M.device_ports(spec, types)
  local list = {}
  for _, c in ipairs(spec.children) do
    local t = c.kind == "leaf" and types[c.type]
    if t then
      for _, dir in ipairs({ "inputs", "outputs" }) do
        for _, p in ipairs(t[dir] or {}) do
          if p.device and p.device ~= "" then
            local signal, err = port_types.device_signal(p.device, t.params, c.args)
            if signal ~= false then  -- false: an unused slot ({joints[7]} of six joints), left unwired
              list[#list + 1] = { leaf = c.path, type = c.type, port = p.name, signal = signal or p.device,
                                  dir = dir == "inputs" and "in" or "out", err = err }
            end
          end
        end
      end
    end
  end
  return list
end

-- "main.door.xr4000 (XR4000Ctrl: Cmd -> base.cmd_vel, Odom <- base.pose)", one per leaf
local function describe_devices(ports)
  local by_leaf, order = {}, {}
  for _, p in ipairs(ports) do
    local l = by_leaf[p.leaf]
    if not l then l = { type = p.type, parts = {} } by_leaf[p.leaf] = l order[#order + 1] = p.leaf end
    l.parts[#l.parts + 1] = p.dir == "in" and (p.port .. " <- " .. p.signal) or (p.port .. " -> " .. p.signal)
  end
  local out = {}
  for _, leaf in ipairs(order) do
    out[#out + 1] = sformat("%s (%s: %s)", leaf, by_leaf[leaf].type, concat(by_leaf[leaf].parts, ", "))
  end
  return concat(out, "; ")
end

-- (the start protocol, phase 2b) Device ports of this group's leaves wired to the robot process `world` (ARCHITECTURE.md, "The
-- robot: device ports"): an input's signal world -> leaf, an output leaf -> world, in the set
-- "<leaf path>:device", activated at once and for good (the algebra never touches these sets).
-- With `only` (a leaf path: a restarted leaf), that leaf's device ports only.
function M.devices(sup, cb, only)
  local types = sup.rt.types and sup.rt.types() or {}
  local ports = M.device_ports(sup.spec, types)
  if only then
    local mine = {}
    for _, p in ipairs(ports) do if p.leaf == only then mine[#mine + 1] = p end end
    ports = mine
  else
    sup.device_ports = ports
  end
  if #ports == 0 then cb(true) return end
  local function no_world(err)
    return sformat("%s: no world for the device ports of %s (start it with `dca run --sim WORLD`, or a robot "
      .. "driver registered as `world`): %s", sup.path, describe_devices(ports), tostring(err))
  end
  if not sup.rt.world then cb(nil, no_world("this runtime reaches no world")) return end
  for _, p in ipairs(ports) do
    if p.err then cb(nil, sformat("%s: device port %s.%s: %s", sup.path, p.leaf, p.port, p.err)) return end
  end
  local j, activated = async.join(cb, true), {}
  for _, p in ipairs(ports) do
    local k = j.add()
    local function fail(what, reply, err, missing)
      if missing then k(nil, no_world(err)) return end
      local _, why = async.outcome(reply, err)
      k(nil, sformat("%s: %s device port %s.%s (%s): %s", sup.path, what, p.leaf, p.port, p.signal, why))
    end
    local set = p.leaf .. ":device"
    -- the source of the connection: the world for an input, the leaf for an output
    local function at_source(msg, k)
      if p.dir == "in" then sup.rt.world(msg, sup.timeouts.connect, k)
      else M.to_leaf(sup, p.leaf, msg, sup.timeouts.connect, k) end
    end
    -- a queue of one: a device port holds the robot's latest reading or command (the set is active while
    -- the leaf waits inactive: older samples would pile up and be read stale when it runs)
    local conn = p.dir == "in"
      and { type = "connect", out = p.signal, to = p.leaf, ["in"] = p.port, set = set, mode = "push", queue = 1 }
      or { type = "connect", out = p.port, to = "world", ["in"] = p.signal, set = set, mode = "push", queue = 1 }
    at_source(conn, function(reply, err, missing)
      if j.over() then return end
      if not async.outcome(reply, err) then fail("connecting", reply, err, missing) return end
      local key = p.dir .. " " .. set
      if activated[key] then k(true) return end
      activated[key] = true
      at_source({ type = "activate", set = set }, function(r2, e2)
        if async.outcome(r2, e2) then k(true) else fail("activating", r2, e2) end
      end)
    end)
  end
  j.close()
end

function M.is_device_input(sup, leaf, port)
  for _, p in ipairs(sup.device_ports or {}) do
    if p.leaf == leaf and p.port == port and p.dir == "in" then return true end
  end
  return false
end

---------------------------------------------------------------------------------------------- ports of new code

local WORD = { inputs = "input", outputs = "output" }

-- The port `name` in a list of port specs ({name, type, size}), or nil.
local function port_in(list, name)
  for _, p in ipairs(list or {}) do if p.name == name then return p end end
end

-- The manifest port of leaf `path` (a leaf of this group's tree, by its type in `types`), in `dir`, or nil.
local function manifest_port(sup, types, path, dir, name)
  local t
  spec_mod.walk(sup.spec, function(n) if n.kind == "leaf" and n.path == path then t = types[n.type] end end)
  return t and port_in(t[dir], name)
end

-- The uses this group knows of leaf `path`'s ports: its connections (the peer's port named, to check the shape
-- against), its device ports and its external_io aliases naming them (groups above may connect those; their
-- direction and shape are the old code's). { { dir, port, what, peer = {path, dir, port} | nil }, ... }
local function port_uses(sup, path, types)
  local uses = {}
  for _, w in ipairs(sup.wires or {}) do
    local what = sformat("connection %s.%s -> %s.%s (set %s)", w.src, w.out, w.dst, w["in"], w.set)
    if w.src == path then
      uses[#uses + 1] = { dir = "outputs", port = w.out, what = what, peer = { w.dst, "inputs", w["in"] } }
    end
    if w.dst == path then
      uses[#uses + 1] = { dir = "inputs", port = w["in"], what = what, peer = { w.src, "outputs", w.out } }
    end
  end
  for _, p in ipairs(M.device_ports(sup.spec, types)) do
    if p.leaf == path then
      uses[#uses + 1] = { dir = p.dir == "in" and "inputs" or "outputs", port = p.port,
                          what = "its device port " .. (p.dir == "in" and "from " or "to ") .. p.signal }
    end
  end
  for _, x in ipairs(sup.spec.external_io or {}) do
    local c = spec_mod.child(sup.spec, x.instance)
    if c and c.path == path then
      local t = types[c.type] or {}
      local dir = port_in(t.outputs, x.port) and "outputs" or port_in(t.inputs, x.port) and "inputs" or nil
      uses[#uses + 1] = { dir = dir, port = x.port, what = sformat("external_io %s of %s", x.alias, sup.path) }
    end
  end
  return uses
end

local function names(list)
  local out = {}
  for _, p in ipairs(list or {}) do out[#out + 1] = tostring(p.name) end
  return #out > 0 and concat(out, ", ") or "none"
end

-- What is wrong with use `u` of the new ports `got` of the leaf (nil: nothing). `old`: its type's manifest as
-- the system was checked with it (a port of the same type and size fits as it did).
local function use_problem(sup, types, got, u, old)
  local dirs = u.dir and { u.dir } or { "inputs", "outputs" }
  local new, dir
  for _, d in ipairs(dirs) do
    new = port_in(got[d], u.port)
    if new then dir = d break end
  end
  if not new then
    if u.dir then
      return sformat("its new code has no %s '%s' (%s are: %s), which %s uses", WORD[u.dir], u.port, u.dir,
        names(got[u.dir]), u.what)
    end
    return sformat("its new code has no port '%s' (inputs are: %s; outputs are: %s), which %s uses", u.port,
      names(got.inputs), names(got.outputs), u.what)
  end
  local shape = port_types.shape(new)
  local was = old and port_types.shape(port_in(old[dir], u.port))
  -- the same type and size as the code the system was checked with: it fits as it did
  if not shape or (was and port_types.text(was) == port_types.text(shape)) then return nil end
  local pp = u.peer and manifest_port(sup, types, u.peer[1], u.peer[2], u.peer[3])
  local peer = pp and port_types.shape(pp)
  if peer then
    local ok = dir == "outputs" and port_types.fits(shape, peer) or dir == "inputs" and port_types.fits(peer, shape)
    if ok then return nil end
    return sformat("its new code's %s '%s' is a %s, which does not fit %s: %s.%s is a %s", WORD[dir], u.port,
      port_types.text(shape), u.what, u.peer[1], u.peer[3], port_types.text(peer))
  end
  if was then
    return sformat("its new code's %s '%s' is a %s, not the %s it was, which %s needs", WORD[dir], u.port,
      port_types.text(shape), port_types.text(was), u.what)
  end
end

--- Why the ports `got` (a node's `ports {}` answer: inputs and outputs, each {name, type, size}) of the new
--- process of leaf `path` (a restart) do not fit what this group knows the system does with that leaf: its
--- connections (the name, the direction, and the type and size against the other end's), its device ports and
--- its external_io aliases (the name and direction, and the type and size the old code had). nil when they fit,
--- or when the answer lists no ports (a runtime whose nodes do not tell).
function M.ports_mismatch(sup, path, got)
  if type(got) ~= "table" or (got.inputs == nil and got.outputs == nil) then return nil end
  local types = sup.rt.types and sup.rt.types() or {}
  local leaf
  spec_mod.walk(sup.spec, function(n) if n.kind == "leaf" and n.path == path then leaf = n end end)
  local old = leaf and types[leaf.type]
  local problems, seen = {}, {}
  for _, u in ipairs(port_uses(sup, path, types)) do
    local why = use_problem(sup, types, got, u, old)
    if why and not seen[why] then seen[why] = true problems[#problems + 1] = why end
  end
  if #problems == 0 then return nil end
  return sformat("restart of %s refused: %s", path, concat(problems, "; "))
end

--- Asks the new process `handle` of leaf `path` for its ports and checks them against the system's uses of
--- them (M.ports_mismatch), before anything is wired to it. cb(true) | cb(nil, reason)
function M.check_ports(sup, path, handle, cb)
  handle.request({ type = "ports" }, sup.timeouts.request, function(r, err)
    local got, why = async.outcome(r, err)
    if not got then cb(nil, sformat("%s: its new process did not list its ports: %s", path, why)) return end
    why = M.ports_mismatch(sup, path, got)
    if why then cb(nil, why) else cb(true) end
  end)
end

-- Whether the leaf `leaf` is `path` or lies below it (a restarted group's subtree).
local function under(leaf, path) return leaf == path or leaf:sub(1, #path + 1) == path .. "." end

--- Makes again this group's connections of leaf `path` (started anew), or of every leaf below the group `path`
--- (a subtree started anew): each one it is the source of at the new process, each one it is the destination of
--- at its source, whose endpoint replaces its link to the old process (host/endpoint); each activated at its
--- source when its set is active. cb(true) | cb(nil, reason)
function M.rewire(sup, path, cb)
  local list = {}
  for _, w in ipairs(sup.wires or {}) do
    -- (a connection with a child still waiting for its own restart is made when that one is started)
    local other = under(w.src, path) and w.dst or w.src
    if (under(w.src, path) or under(w.dst, path)) and (under(other, path) or not M.pending(sup, other)) then
      list[#list + 1] = w
    end
  end
  M.connect_wires(sup, list, cb, function(w, k)
    -- the set active again at a new source: this one, or one started earlier by the same restart whose
    -- connection waited for this one
    if not (sup.active_sets and sup.active_sets[w.set]) or not (under(w.src, path) or M.fresh(sup, w.src)) then
      k(true)
      return
    end
    local src = M.replayed(sup, w.src, w.out) and M.WORLD or w.src
    M.at_source(sup, src, { type = "activate", set = w.set }, sup.timeouts.connect, function(r, err)
      local ok, why = async.outcome(r, err)
      if ok then k(true) return end
      k(nil, sformat("%s: activating %s at %s: %s", sup.path, w.set, w.src, why))
    end)
  end)
end

-- Whether the process of leaf `leaf` is being started anew by this group's restart and is not up yet.
function M.pending(sup, leaf)
  local ch = sup:_via(leaf)
  return ch ~= nil and child.restart(ch, "replacing") == true and ch.handle == nil
end

-- Whether the process of leaf `leaf` was started anew by the restart in progress (dca.supervisor.restart).
function M.fresh(sup, leaf)
  local ch = sup:_via(leaf)
  return ch ~= nil and sup.recovering ~= nil and sup.recovering.started[ch.name] == true
end

return M
