-- dca.supervisor.wiring: a group's connections and device ports, made at its start and again after a restart,
-- as functions over the supervisor `sup` (dca.supervisor). Commands reach a leaf through wiring.to_leaf.
--
--   wiring.to_leaf(sup, leaf_path, msg, timeout, cb)  -- to the node of a leaf: directly when it is a child, else
--                                   --   through the child supervisor whose subtree holds it. cb(reply, err)
--   wiring.connect(sup, cb)         -- the group's own connections, created inactive at each source node
--   wiring.devices(sup, cb, only)   -- the device ports of its leaves (of leaf `only`) wired to the world
--   wiring.rewire(sup, path, cb)    -- its connections of the leaf or subtree `path` (started anew) made again
--   wiring.device_ports(spec, types)   --> the device ports of the group's own leaves
--   wiring.is_device_input(sup, leaf, port)  --> whether that port of that leaf is a device input
-- cb(true) | cb(nil, the first reason, naming the connection or port).
local M = {}

local async = require "dca.async"
local child = require "dca.supervisor.child"
local port_types = require "dca.lang.ports"
local spec_mod = require "dca.supervisor.spec"
local taps = require "dca.supervisor.taps"

local ipairs, tostring, sformat, concat = ipairs, tostring, string.format, table.concat

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

-- (the start protocol, phase 2) This group's own connections, resolved to leaf ports, created inactive at each source node.
function M.connect(sup, cb)
  local wires, errs = spec_mod.wiring(sup.spec)
  if not wires then cb(nil, concat(errs, "; ")) return end
  sup.wires = wires
  sup.set_sources = {}
  for _, w in ipairs(wires) do
    local s = sup.set_sources[w.set]
    if not s then s = {} sup.set_sources[w.set] = s end
    if not s[w.src] then s[w.src] = true s[#s + 1] = w.src end
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

-- One connection `w` (from spec_mod.wiring) made at its source node. cb(true) | cb(nil, reason naming it)
function M.connect_wire(sup, w, cb)
  M.to_leaf(sup, w.src, { type = "connect", out = w.out, to = w.dst, ["in"] = w["in"], set = w.set, mode = "push" },
    sup.timeouts.connect, function(reply, err)
      local ok, why = async.outcome(reply, err)
      if ok then cb(true) return end
      cb(nil, sformat("%s: connecting %s.%s -> %s.%s (set %s): %s", sup.path, w.src, w.out, w.dst, w["in"], w.set, why))
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
            list[#list + 1] = { leaf = c.path, type = c.type, port = p.name, signal = signal or p.device,
                                dir = dir == "inputs" and "in" or "out", err = err }
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
    M.to_leaf(sup, w.src, { type = "activate", set = w.set }, sup.timeouts.connect, function(r, err)
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
