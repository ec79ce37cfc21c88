-- dca.load: a .dca file from disk to what runs it: read -> parse -> check -> build -> spec.
--
--   local load = require "dca.load"
--   local ast, tree = load.file("door_open.dca", { root = "main", registry = true })  -- | nil, error text
--   local spec, tree, ast = load.spec("door_open.dca", { root = "main", world = "door" }) -- | nil, error text
--
-- The error text is what `dca check` prints: every error as "file:line:col: path: message", the source line
-- and a caret. With registry (the default) the controller registry's manifests (dca.core.types()) check the
-- leaves' ports and parameters; registry = false takes undefined process types as leaves.
--
-- The world: the leaves' device ports are held to the signals of `world`, the spec `dca run --sim` takes
-- ("door", the default; ROBOT.urdf; mock:ROBOT.urdf?...; core.world_signals). A world that cannot be loaded (a
-- URDF's FILE:LINE:COL) is one more error, after the file's; world = false holds the device ports to nothing.
--
-- Packages: the file's `use NAME;` statements load those controller packages into this process (dca.core
-- .load_package, searched on DCA_CONTROLLER_PATH, <prefix>/lib/dca/controllers and the file's packages/ folder:
-- ARCHITECTURE.md, "Controller packages"); the check sees the built-in types and those of the packages the file
-- uses, no others. A package that cannot be loaded is an error at its `use`. Each leaf of the spec names the
-- package of its type and the file's folder (`package`, `system_dir`), which its node loads the same way.
local parser = require "dca.lang.parser"
local check = require "dca.lang.check"
local model = require "dca.lang.model"

local M = {}

--- The controller registry's manifests, when dca.core provides them (nil otherwise).
function M.registry()
  local ok, core = pcall(require, "dca.core")
  if ok and type(core) == "table" and type(core.types) == "function" then
    local ok2, types = pcall(core.types)
    if ok2 and type(types) == "table" then return types end
  end
  return nil
end

local function core_or_nil()
  local ok, core = pcall(require, "dca.core")
  if ok and type(core) == "table" and type(core.load_package) == "function" then return core end
  return nil
end

--- The folder of the file at `path` ("." for a bare name).
local function folder(path)
  return tostring(path):match("^(.*)/[^/]*$") or "."
end

--- Loads the packages `ast` uses. --> { [name] = { types = {...} } | { error = "..." } } | nil without dca.core
function M.packages(ast, path)
  local core = core_or_nil()
  if not core then return nil end
  local out = {}
  for _, u in ipairs(ast.uses or {}) do
    if not out[u.name] then
      local p, err = core.load_package(u.name, folder(path))
      out[u.name] = p or { error = err }
    end
  end
  return out
end

--- The signals of world `spec` (nil: the door; a table: those signals) which the device ports are held to: nil
--- when there are none to hold them to (world = false, or an executable without the worlds).
--- --> signals | nil | nil, error
local function world_signals(core, spec)
  if type(spec) == "table" then return spec end  -- a robot's driver's ports (dca.launch.driver)
  if spec == false or not (core and type(core.world_signals) == "function") then return nil end
  return core.world_signals(spec)
end

--- The check options for `ast`: the registry's manifests of the built-ins and the used packages' types; the
--- types of other loaded packages as hints; the signals of `world` (see the header), or the reason it has none
--- (world_error). --> opts for dca.lang.check (without root)
function M.check_options(ast, path, registry, world)
  if registry == false then return {} end
  local packages = M.packages(ast, path) or {}
  local all = M.registry()
  if not all then return {} end
  local types, elsewhere, ambiguous = {}, {}, {}
  local of_used = {}  -- a type's name -> the manifests of the used packages that define it
  for name, m in pairs(all) do
    if not m.package then
      types[name] = m
    elseif name:find(".", 1, true) then  -- each package type once, under package.name
      local t = m.type or name:match("[^.]+$")
      if packages[m.package] and not packages[m.package].error then
        types[name] = m
        of_used[t] = of_used[t] or {}
        table.insert(of_used[t], m)
      else
        elsewhere[name] = m.package
        elsewhere[t] = elsewhere[t] or m.package
      end
    end
  end
  -- a name one used package defines is the type; one several define must be written package.name
  for t, list in pairs(of_used) do
    if #list == 1 then
      types[t], elsewhere[t] = list[1], nil
    else
      local names = {}
      for _, m in ipairs(list) do names[#names + 1] = m.package end
      table.sort(names)
      ambiguous[t] = names
    end
  end
  -- the packages on the search path the file does not use (names only: nothing of them is loaded), for hints
  local core, unused = core_or_nil(), {}
  for _, name in ipairs(core and core.packages(folder(path)) or {}) do
    if not packages[name] then unused[#unused + 1] = name end
  end
  -- the robot process's signals, which the device ports are held to (nil in an executable without the world)
  local signals, werr = world_signals(core, world)
  return { types = types, packages = packages, elsewhere = elsewhere, ambiguous = ambiguous, unused_packages = unused,
           world = signals, world_error = werr }
end

--- The whole text of the file at path. --> text | nil, "dca: cannot read ..."
function M.read(path)
  local f, err = io.open(path, "rb")
  if not f then return nil, "dca: cannot read " .. tostring(err) end
  local text = f:read("a")
  f:close()
  return text
end

--- Reads, parses, checks and builds the file. opts: { root = NAME, registry = true|false (default true),
--- world = SPEC | false (default "door": see the header) }.
--- --> ast, tree (tree nil when no root was asked for and the file has no 'main') | nil, error text
function M.file(path, opts)
  local text, rerr = M.read(path)
  if not text then return nil, rerr end
  return M.text(text, path, opts)
end

-- The file's errors, then the world's (once: it is no error of any one leaf). --> nil, the text
local function failure(ast, errors, world_error)
  local parts = {}
  if errors and #errors > 0 then parts[1] = check.format_all(ast, errors) end
  if world_error then parts[#parts + 1] = world_error end
  return nil, table.concat(parts, "\n")
end

--- As M.file, for source text already read; `path` names it in errors.
function M.text(text, path, opts)
  opts = opts or {}
  local ast, perr = parser.parse(text, path)
  if not ast then return nil, perr end
  local copts = M.check_options(ast, path, opts.registry, opts.world)
  local werr = copts.world_error
  copts.root, copts.world_error = opts.root, nil
  if not opts.root and not ast.by_name.main then
    local errors = check.check(ast, copts)
    if #errors > 0 or werr then return failure(ast, errors, werr) end
    return ast, nil
  end
  local tree, errors = model.build(ast, copts)
  if not tree or werr then return failure(ast, errors, werr) end
  return ast, tree
end

--- The file as far as the spec of its root (dca.supervisor.spec, validated). opts as for M.file.
--- --> spec, tree, ast | nil, error text
function M.spec(path, opts)
  opts = opts or {}
  local ast, tree = M.file(path, opts)
  if not ast then return nil, tree end
  if not tree then return nil, path .. ": no process '" .. (opts.root or "main") .. "' to run" end
  local spec_mod = require "dca.supervisor.spec"
  local spec = spec_mod.from_model(tree, path)
  local errs = spec_mod.validate(spec)
  if #errs > 0 then return nil, table.concat(errs, "\n") end
  local core = core_or_nil()
  if core then
    -- the nodes of package types load them from the same search path, this file's folder included
    local dir = core.absolute(folder(path))
    spec_mod.walk_all(spec, function(n) if n.package then n.system_dir = dir end end)
  end
  return spec, tree, ast
end

return M
