-- dca.supervisor.taps: taps on output ports by path (host/tap.h, ARCHITECTURE.md "Taps"), made by a supervisor
-- that reaches the ports' leaves (the root reaches every leaf through the tree). Pure of dca.core: the
-- manifests come from the caller, the links go through sup:to_leaf.
--
--   taps.outputs(spec, types)             --> every output of the tree's leaves, in tree order:
--                                             { { path = "main.door.hit.Out", leaf = "main.door.hit", port = "Out",
--                                                 type = "vector", size = 3, units = "",
--                                                 message = nil (a message port's ROS 2 type) }, ... }
--   taps.select(spec, types, "all" | "a.b.P,c.d.Q")  --> those outputs | nil, err (every unknown path named, with
--                                             the outputs of its leaf when the leaf exists)
--   taps.connect(sup, list, to, opts, cb)  -- each output linked to the tap input "tap:PATH" of component `to`
--                                             (stamped, in its own set "tap:PATH", activated); opts.prepare(p, k)
--                                             first if given (e.g. the world's `tap` request; k(true) |
--                                             k(nil, err)), opts.queue (the tap input's queue, default 256),
--                                             opts.send(leaf, msg, timeout, cb(reply | nil, err)) (default
--                                             sup:to_leaf: e.g. the world's own signals go to the world).
--                                             cb(true) | cb(nil, the first error, naming the port)
--   taps.request(sup, msg, reply)          -- a console's `ports {}` or `tap {path, to}` request (below)
-- A supervisor remembers the taps made through it on the child they pass (taps.note, from sup:to_leaf) and makes
-- them again after that child's restart (taps.retap).
local M = {}

local async = require "dca.async"
local spec_mod = require "dca.supervisor.spec"

local ipairs, type, sformat, tostring, concat = ipairs, type, string.format, tostring, table.concat

--- The tap input and set of the output at `path` (host/tap.h tap::input_name).
function M.input(path) return "tap:" .. path end

function M.outputs(spec, types)
  local list = {}
  spec_mod.walk(spec, function(n)
    if n.kind ~= "leaf" then return end
    local t = types[n.type]
    for _, o in ipairs(t and t.outputs or {}) do
      list[#list + 1] = { path = n.path .. "." .. o.name, leaf = n.path, port = o.name, type = o.type,
                          size = o.size, units = o.units or "", message = o.message }
    end
  end)
  return list
end

function M.select(spec, types, selection)
  local all = M.outputs(spec, types)
  if selection == "all" then return all end
  local by_path, leaves = {}, {}
  for _, o in ipairs(all) do
    by_path[o.path] = o
    local l = leaves[o.leaf] or {}
    leaves[o.leaf] = l
    l[#l + 1] = o.port
  end
  spec_mod.walk(spec, function(n) if n.kind == "leaf" then leaves[n.path] = leaves[n.path] or {} end end)
  local out, errs, seen = {}, {}, {}
  for path in tostring(selection):gmatch("[^,%s]+") do
    local o = by_path[path]
    if o and not seen[path] then seen[path] = true out[#out + 1] = o
    elseif not o then
      local leaf, port = path:match("^(.*)%.([^.]+)$")
      if leaf and leaves[leaf] then
        errs[#errs + 1] = sformat("%s has no output '%s' (outputs: %s)", leaf, port,
          #leaves[leaf] > 0 and concat(leaves[leaf], ", ") or "none")
      else
        errs[#errs + 1] = sformat("no leaf %s in %s (a port is named PATH.PORT, e.g. main.arm.pd.Out)",
          tostring(leaf or path), spec.path)
      end
    end
  end
  if #errs > 0 then return nil, concat(errs, "; ") end
  if #out == 0 then return nil, "no port named (PATH.PORT,... or all)" end
  return out
end

-- One tap: prepared, linked, activated. k(true) | k(nil, err)
local function tap_one(sup, p, to, opts, k)
  local set = M.input(p.path)
  local function fail(what, r, err)
    local _, why = async.outcome(r, err)
    k(nil, sformat("tap %s: %s: %s", p.path, what, why))
  end
  local send = opts.send or function(leaf, msg, timeout, cb) sup:to_leaf(leaf, msg, timeout, cb) end
  local function link()
    send(p.leaf, { type = "connect", out = p.port, to = to, ["in"] = set, set = set, mode = "push",
                   queue = opts.queue or 256, stamped = true }, sup.timeouts.connect, function(r, err)
      if not async.outcome(r, err) then fail("connecting", r, err) return end
      send(p.leaf, { type = "activate", set = set }, sup.timeouts.connect, function(r2, err2)
        if not async.outcome(r2, err2) then fail("activating", r2, err2) return end
        k(true)
      end)
    end)
  end
  if not opts.prepare then link() return end
  opts.prepare(p, function(ok, err)
    if not ok then k(nil, sformat("tap %s: %s", p.path, tostring(err))) return end
    link()
  end)
end

function M.connect(sup, list, to, opts, cb)
  opts = opts or {}
  local j = async.join(cb, true)
  for _, p in ipairs(list) do tap_one(sup, p, to, opts, j.add()) end
  j.close()
end

-- A tap's link to a leaf of child `ch` (the leaf itself, or one in its subtree: dca.supervisor.taps: a stamped
-- connect, the activation of its set "tap:..."), remembered on the child so that a restart makes it again on the
-- new process (or on every new process of a restarted subtree), inside the restart (taps.retap: so in simulated
-- time at the restart's tick, before the barrier ends).
function M.note(ch, leaf, msg)
  local set = type(msg.set) == "string" and msg.set or ""
  local tap = (msg.type == "connect" and msg.stamped == true) or
    ((msg.type == "activate" or msg.type == "deactivate") and set:sub(1, 4) == "tap:")
  if not tap then return end
  ch.taps = ch.taps or { order = {} }
  local key = leaf .. " " .. set
  local t = ch.taps[key]
  if not t then t = { leaf = leaf, set = set, to = {}, connect = {} } ch.taps[key] = t ch.taps.order[#ch.taps.order + 1] = key end
  if msg.type ~= "connect" then t.active = msg.type == "activate" return end
  -- one link per destination (the run's own tap point, the world's recording, an attached monitor's)
  local to = tostring(msg.to)
  if not t.connect[to] then t.to[#t.to + 1] = to end
  t.connect[to] = msg
end

-- A tap's destination `to` forgotten (its link failed on a restart: a closed monitor's tap point is not waited for
-- again at the next one).
function M.forget(t, to)
  if not (to and t.connect[to]) then return end
  t.connect[to] = nil
  for i, x in ipairs(t.to) do if x == to then table.remove(t.to, i) break end end
end

-- The taps remembered for child `ch` made again (each destination's link connected, then the set activated if it
-- was), k() after; a link that fails (e.g. its tap point is gone) is logged and forgotten, the others and the
-- restart go on.
function M.retap(sup, ch, k)
  local j = async.join(function() k() end)
  for _, key in ipairs(ch.taps and ch.taps.order or {}) do
    local t, made = ch.taps[key], j.add()
    local links = async.join(function()
      if not t.active then made(true) return end
      sup:to_leaf(t.leaf, { type = "activate", set = t.set }, sup.timeouts.connect, function() made(true) end)
    end)
    for _, to in ipairs({ table.unpack(t.to) }) do
      local linked = links.add()
      sup:to_leaf(t.leaf, t.connect[to], sup.timeouts.connect, function(r, err)
        local ok, why = async.outcome(r, err)
        if not ok then
          sup:log("%s: tap %s of restarted %s: %s", sup.path, t.set, t.leaf, why)
          M.forget(t, to)
        end
        linked(true)
      end)
    end
    links.close()
  end
  j.close()
end

-- A console's taps (`dca monitor ADDR` plotting a port): `ports {}` --> {ports = taps.outputs of the tree, host,
-- sim (on simulated time: the samples' stamps mean something to a viewer)};
-- `tap {path = "a.b.P", to = NAME}` links that output to the tap input "tap:a.b.P" of the component NAME (a tap
-- point the console registered), through the tree as the root's own taps (so a restart makes it again).
function M.request(sup, msg, reply)
  local types = sup.rt.types and sup.rt.types() or {}
  if msg.type == "ports" then reply({ type = "ok", ports = M.outputs(sup.spec, types), host = sup.spec.host,
                                         sim = (sup.rt.on_sim_time and sup.rt.on_sim_time()) == true }) return end
  if type(msg.path) ~= "string" or type(msg.to) ~= "string" or msg.to == "" then
    reply({ type = "error", reason = "tap {path = 'a.b.PORT', to = 'NAME'}" }) return
  end
  local list, err = M.select(sup.spec, types, msg.path)
  if list and #list ~= 1 then list, err = nil, "tap one port at a time, not '" .. msg.path .. "'" end
  if not list then reply({ type = "error", reason = err }) return end
  M.connect(sup, list, msg.to, {}, function(ok, cerr)
    reply(ok and { type = "ok", port = list[1] } or { type = "error", reason = cerr })
  end)
end

return M
