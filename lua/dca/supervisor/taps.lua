-- dca.supervisor.taps: taps on output ports by path (host/tap.h, ARCHITECTURE.md "Taps"), made by a supervisor
-- that reaches the ports' leaves (the root reaches every leaf through the tree). Pure of dca.core: the
-- manifests come from the caller, the links go through sup:to_leaf.
--
--   taps.outputs(spec, types)             --> every output of the tree's leaves, in tree order:
--                                             { { path = "main.door.hit.Out", leaf = "main.door.hit", port = "Out",
--                                                 type = "vector", size = 3, units = "" }, ... }
--   taps.select(spec, types, "all" | "a.b.P,c.d.Q")  --> those outputs | nil, err (every unknown path named, with
--                                             the outputs of its leaf when the leaf exists)
--   taps.connect(sup, list, to, opts, cb)  -- each output linked to the tap input "tap:PATH" of component `to`
--                                             (stamped, in its own set "tap:PATH", activated); opts.prepare(p, k)
--                                             first if given (e.g. the world's `tap` request; k(true) |
--                                             k(nil, err)), opts.queue (the tap input's queue, default 256),
--                                             opts.send(leaf, msg, timeout, cb(reply | nil, err)) (default
--                                             sup:to_leaf: e.g. the world's own signals go to the world).
--                                             cb(true) | cb(nil, the first error, naming the port)
local spec_mod = require "dca.supervisor.spec"

local M = {}

local ipairs, sformat, tostring, concat = ipairs, string.format, tostring, table.concat

--- The tap input and set of the output at `path` (host/tap.h tap::input_name).
function M.input(path) return "tap:" .. path end

function M.outputs(spec, types)
  local list = {}
  spec_mod.walk(spec, function(n)
    if n.kind ~= "leaf" then return end
    local t = types[n.type]
    for _, o in ipairs(t and t.outputs or {}) do
      list[#list + 1] = { path = n.path .. "." .. o.name, leaf = n.path, port = o.name, type = o.type,
                          size = o.size, units = o.units or "" }
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
        errs[#errs + 1] = sformat("no leaf %s in %s (a port is named PATH.PORT, e.g. main.door.hit.Out)",
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
    k(nil, sformat("tap %s: %s: %s", p.path, what, r and r.reason or tostring(err)))
  end
  local send = opts.send or function(leaf, msg, timeout, cb) sup:to_leaf(leaf, msg, timeout, cb) end
  local function link()
    send(p.leaf, { type = "connect", out = p.port, to = to, ["in"] = set, set = set, mode = "push",
                   queue = opts.queue or 256, stamped = true }, sup.timeouts.connect, function(r, err)
      if not r or r.type == "error" then fail("connecting", r, err) return end
      send(p.leaf, { type = "activate", set = set }, sup.timeouts.connect, function(r2, err2)
        if not r2 or r2.type == "error" then fail("activating", r2, err2) return end
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
  local left, failed = #list, false
  if left == 0 then cb(true) return end
  for _, p in ipairs(list) do
    tap_one(sup, p, to, opts, function(ok, err)
      if failed then return end
      if not ok then failed = true cb(nil, err) return end
      left = left - 1
      if left == 0 then cb(true) end
    end)
  end
end

return M
