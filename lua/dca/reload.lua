-- dca.reload: a running system takes a new version of its system file or of its Lua modules, validated
-- first, so that a broken edit never replaces what runs.
--
--   local reload = require "dca.reload"
--   reload.system(sup, "door_open.dca", { root = "main" }, function(lines, err) end)
--   local lines = reload.modules()        -- the supervisor and its console, in place
--
-- reload.system reads, parses and checks the file and builds its spec (dca.load.spec); only a spec that
-- passes goes to the root supervisor (sup:update, which reports what changed and when it takes effect).
-- On an error the running version stays and cb(nil, err) gets the text (file:line:col). sup is anything
-- with update(spec, cb(lines)): the root supervisor, or a proxy that forwards the request to it.
--
-- reload.modules loads each module's file again and runs it; a module that does not compile or run is left
-- as it was and its line says why. The supervisor keeps its state in its objects (dca.supervisor), so the
-- groups that run keep running, with the new methods.
local load = require "dca.load"

local M = {}

--- The modules reload.modules() reloads by default.
M.MODULES = { "dca.supervisor", "dca.supervisor.console" }

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
  package.loaded[name] = mod
  return name .. ": reloaded (state kept)"
end

--- Reloads the modules (default M.MODULES) in place. --> lines, one per module
function M.modules(names)
  local lines = {}
  for i, name in ipairs(names or M.MODULES) do lines[i] = module(name) end
  return lines
end

return M
