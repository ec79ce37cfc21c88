-- dca.reload: a running system takes a new version of its system file or of its Lua modules, validated
-- first, so that a broken edit never replaces what runs.
--
--   local reload = require "dca.reload"
--   reload.system(sup, "door_open.dca", { root = "main" }, function(lines, err) end)
--   local lines = reload.modules()        -- every module of the supervisor (dca.supervisor.*), in place
--
-- reload.system reads, parses and checks the file and builds its spec (dca.load.spec); only a spec that
-- passes goes to the root supervisor (sup:update, which reports what changed and when it takes effect).
-- On an error the running version stays and cb(nil, err) gets the text (file:line:col). sup is anything
-- with update(spec, cb(lines)): the root supervisor, or a proxy that forwards the request to it.
--
-- reload.modules loads each module's file again and runs it; a module that does not compile or run is left
-- as it was and its line says why. The new version's fields are copied into the table the module had, so that
-- whoever holds that table (every `local x = require "..."`) calls the new functions; a field the new version
-- no longer has stays. The supervisor keeps its state in its objects (dca.supervisor), so the groups that run
-- keep running, with the new code.
local load = require "dca.load"

local M = {}

--- The modules reload.modules() reloads by default: every dca.supervisor.* module loaded (sorted), then the
--- supervisor itself; its console always.
function M.default_modules()
  local names = {}
  for name in pairs(package.loaded) do
    if name:match("^dca%.supervisor%.") then names[#names + 1] = name end
  end
  if not package.loaded["dca.supervisor.console"] then names[#names + 1] = "dca.supervisor.console" end
  table.sort(names)
  names[#names + 1] = "dca.supervisor"
  return names
end

--- Validates the system file and hands its spec to sup. cb(lines) (what changed, possibly none) or cb(nil, err).
function M.system(sup, file, opts, cb)
  local spec, err = load.spec(file, opts)
  if not spec then cb(nil, err) return end
  sup:update(spec, function(lines) cb(lines or {}) end)
end

--- Loads and runs one module's file again: package.loaded[name] is replaced only when both succeed.
--- --> the line that says what happened
local function module(name)
  local path, serr = package.searchpath(name, package.path)
  if not path then return name .. ": " .. tostring(serr) end
  local fn, lerr = loadfile(path)
  if not fn then return lerr end
  local ok, mod = pcall(fn, name)
  if not ok then return name .. ": " .. tostring(mod) end
  local old = package.loaded[name]
  if type(old) == "table" and type(mod) == "table" and old ~= mod then
    for k, v in pairs(mod) do old[k] = v end
    mod = old
  end
  package.loaded[name] = mod
  return name .. ": reloaded (state kept)"
end

--- Reloads the modules (default M.default_modules()) in place. --> lines, one per module
function M.modules(names)
  local lines = {}
  for i, name in ipairs(names or M.default_modules()) do lines[i] = module(name) end
  return lines
end

return M
