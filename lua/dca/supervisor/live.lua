-- dca.supervisor.live: parameters that change while a system runs (docs/configuration.md, "Live parameters").
-- A leaf's argument written `config("key")` is read when the leaf starts; once this group is up, the supervisor
-- also watches each such key on the configuration repository of its host (rt.config_client: local writes and
-- replicated ones). When one changes, every leaf of this group whose process is up and whose argument reads that
-- key is told: a parameter its type declares live gets `set_param {name, value}` on the leaf's control channel
-- (host/node.h; the controller checks the value as at construction, dca/controller.h), and the outcome is said
-- at the leaf ("main.ctl.pid: kp = 2.5 (live)", "main.ctl.pid: kp not changed: <why>": the leaf keeps its value
-- and runs on); a parameter that is not live is said to apply at the leaf's next start (a restart reads it).
--
--   live.watch(sup, cb)            -- the keys of this group's leaves watched (a step of the start); cb(true),
--                                  --   also when there is no repository (nothing then changes while it runs)
--   live.changed(sup, key, value)  -- one change of `key`: the leaves told, a line each
--   live.unwatch(sup)              -- the watches ended (shutdown)
-- Pure: the repository's client and the leaves' handles come from the runtime.
local M = {}

local ipairs, pairs, type, tostring, next = ipairs, pairs, type, tostring, next
local sformat = string.format

-- The states in which a leaf's process is up (dca.supervisor.child): it may take a parameter.
local UP = { inactive = true, running = true, stopping = true, done = true, aborted = true }

-- The key a leaf's argument reads (dca.config.param_key), or nil.
local function key_of(arg) return require("dca.config").param_key(arg) end

-- This group's leaves' parameters reading `key` (every key when nil): { { name, param, live, key } ... }
local function readers(sup, key)
  local out = {}
  for _, c in ipairs(sup.spec.children) do
    if c.kind == "leaf" then
      for i, a in ipairs(c.args or {}) do
        local k = key_of(a)
        if k and (key == nil or k == key) then
          local p = c.params and c.params[i]
          out[#out + 1] = { name = c.name, param = p and p.name or ("parameter " .. i), live = p and p.live, key = k }
        end
      end
    end
  end
  return out
end

function M.watch(sup, cb)
  local keys = {}
  for _, r in ipairs(readers(sup)) do keys[r.key] = true end
  if next(keys) == nil or not sup.rt.config_client then cb(true) return end
  sup.rt.config_client(function(c, err)
    if not c then
      sup:say("%s: configuration changes will not reach its leaves while they run: %s", sup.path, tostring(err))
      cb(true)
      return
    end
    sup.live = { client = c, keys = keys }
    local left = 0
    for _ in pairs(keys) do left = left + 1 end
    for key in pairs(keys) do
      c:watch(key, function(ev) if ev.key == key then M.changed(sup, key, ev.value) end end, function(r, werr)
        if not r then sup:say("%s: changes of config key '%s' not watched: %s", sup.path, key, tostring(werr)) end
        left = left - 1
        if left == 0 then cb(true) end
      end, sup.path)
    end
  end)
end

function M.unwatch(sup)
  local l = sup.live
  sup.live = nil
  if not l then return end
  for key in pairs(l.keys) do l.client:unwatch(key, nil, sup.path) end
end

-- The controller's reason without its "<Type> <path>: " and "parameter 'p' not changed: " (the line names both).
local function reason(ch, param, err)
  err = tostring(err)
  local own = tostring(ch.spec.type) .. " " .. ch.path .. ": "
  if err:sub(1, #own) == own then err = err:sub(#own + 1) end
  local again = "parameter '" .. param .. "' not changed: "
  if err:sub(1, #again) == again then err = err:sub(#again + 1) end
  return err
end

-- A value as a line shows it: a string as it is, a number or a boolean as Lua writes it.
local function show(v) return type(v) == "string" and v or tostring(v) end

-- One leaf told of the change of its parameter `r` to `value`.
local function tell(sup, ch, r, value)
  if not r.live then
    sup:say("%s: %s = %s in the repository (config key '%s'); not live: applies at the leaf's next start (restart)",
      ch.path, r.param, show(value), r.key)
    return
  end
  if type(value) == "table" then
    sup:say("%s: %s not changed: the value of config key '%s' is a table; a controller parameter is a number, a "
      .. "string or a boolean", ch.path, r.param, r.key)
    return
  end
  local handle = ch.handle
  handle.request({ type = "set_param", name = r.param, value = value }, sup.timeouts.request, function(reply, err)
    if ch.handle ~= handle then return end  -- replaced meanwhile: the new process read the repository itself
    if reply and reply.type ~= "error" then
      sup:say("%s: %s = %s (live)", ch.path, r.param, show(reply.value ~= nil and reply.value or value))
    else
      sup:say("%s: %s not changed: %s", ch.path, r.param, reason(ch, r.param, reply and reply.reason or err))
    end
  end)
end

function M.changed(sup, key, value)
  for _, r in ipairs(readers(sup, key)) do
    local ch = sup.children[r.name]
    if ch and ch.handle and UP[ch.state] then tell(sup, ch, r, value) end
  end
end

return M
