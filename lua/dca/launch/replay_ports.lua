-- dca.launch.replay_ports: `dca run --replay REC.mcap --replay-ports PATTERN,...` (docs/recording.md, "Replaying
-- ports"): which controller outputs the replay world writes again from the recording, in place of their live
-- writers. Pure but for core.mcap_read.
--
--   local rp = require "dca.launch.replay_ports"
--   local paths, err = rp.select(spec, types, "main.door.hit,main.arm.pd.Out,world")
--       --> { "main.door.hit.force.Wrench", ... } (every output of the leaves named or below the groups named,
--       --   the ports named, those a `*` pattern matches; `world`: the world's signals, which a replay always
--       --   serves from the file) | nil, every unknown pattern named
--   local ok, err = rp.check(paths, "rec.mcap")   -- every one recorded with numbers, or why not
--   rp.mark(spec, paths)                          -- each group's spec.replay_ports (dca.supervisor.wiring)
local M = {}

local spec_mod = require "dca.supervisor.spec"
local taps = require "dca.supervisor.taps"

local ipairs, sformat, concat = ipairs, string.format, table.concat

-- A `*` pattern as a Lua pattern (the rest literal).
local function glob(p)
  return "^" .. p:gsub("[%^%$%(%)%%%.%[%]%+%-%?]", "%%%0"):gsub("%*", ".*") .. "$"
end

-- The outputs one item matches.
local function matching(all, item)
  local out = {}
  local pat = item:find("*", 1, true) and glob(item)
  for _, o in ipairs(all) do
    local hit
    if pat then hit = o.path:match(pat) or o.leaf:match(pat)
    else hit = o.path == item or o.leaf == item or o.leaf:sub(1, #item + 1) == item .. "." end
    if hit then out[#out + 1] = o end
  end
  return out
end

function M.select(spec, types, selection)
  local all = taps.outputs(spec, types)
  local out, seen, errs = {}, {}, {}
  for item in tostring(selection):gmatch("[^,%s]+") do
    if item ~= "world" then
      local found = matching(all, item)
      if #found == 0 then
        errs[#errs + 1] = sformat("'%s' names no output, leaf or group of %s (a port is PATH.PORT, e.g. "
          .. "main.arm.pd.Out; a leaf or group all its outputs; `*` any text; `world` the world's signals)",
          item, spec.path)
      end
      for _, o in ipairs(found) do
        if not seen[o.path] then seen[o.path] = true out[#out + 1] = o.path end
      end
    end
  end
  if #errs > 0 then return nil, concat(errs, "; ") end
  return out
end

-- The recorded channels of a recording: topic -> the first message's data.
local function channels(file)
  local rec, err = require("dca.core").mcap_read(file)
  if not rec then return nil, file .. ": " .. tostring(err) end
  local first = {}
  for _, m in ipairs(rec.messages) do
    local ch = rec.channels[m.channel]
    if ch and first[ch.topic] == nil then first[ch.topic] = m.data end
  end
  return first
end

function M.check(paths, file)
  if #paths == 0 then return true end
  local first, err = channels(file)
  if not first then return nil, err end
  local errs = {}
  for _, p in ipairs(paths) do
    local topic = "/" .. p:gsub("%.", "/")
    local data = first[topic]
    if not data then
      errs[#errs + 1] = sformat("%s is not recorded in %s (record it with --record-ports)", p, file)
    elseif not data:match('^{"value":[%[%-%dn]') then
      errs[#errs + 1] = sformat("%s is recorded in %s without numbers (a Value or message port): it cannot be "
        .. "replayed", p, file)
    end
  end
  if #errs > 0 then return nil, concat(errs, "; ") end
  return true
end

function M.mark(spec, paths)
  spec_mod.walk(spec, function(n)
    if n.kind == "group" then n.spec.replay_ports = paths end
  end)
end

return M
