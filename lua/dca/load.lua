-- dca.load: a .dca file from disk to what runs it: read -> parse -> check -> build -> spec.
--
--   local load = require "dca.load"
--   local ast, tree = load.file("door_open.dca", { root = "main", registry = true })  -- | nil, error text
--   local spec, tree, ast = load.spec("door_open.dca", { root = "main" })            -- | nil, error text
--
-- The error text is what `dca check` prints: every error as "file:line:col: path: message", the source line
-- and a caret. With registry (the default) the controller registry's manifests (dca.core.types()) check the
-- leaves' ports and parameters; registry = false takes undefined process types as leaves.
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

--- The whole text of the file at path. --> text | nil, "dca: cannot read ..."
function M.read(path)
  local f, err = io.open(path, "rb")
  if not f then return nil, "dca: cannot read " .. tostring(err) end
  local text = f:read("a")
  f:close()
  return text
end

--- Reads, parses, checks and builds the file. opts: { root = NAME, registry = true|false (default true) }.
--- --> ast, tree (tree nil when no root was asked for and the file has no 'main') | nil, error text
function M.file(path, opts)
  local text, rerr = M.read(path)
  if not text then return nil, rerr end
  return M.text(text, path, opts)
end

--- As M.file, for source text already read; `path` names it in errors.
function M.text(text, path, opts)
  opts = opts or {}
  local ast, perr = parser.parse(text, path)
  if not ast then return nil, perr end
  local copts = { root = opts.root, types = opts.registry ~= false and M.registry() or nil }
  if not opts.root and not ast.by_name.main then
    local errors = check.check(ast, copts)
    if #errors > 0 then return nil, check.format_all(ast, errors) end
    return ast, nil
  end
  local tree, errors = model.build(ast, copts)
  if not tree then return nil, check.format_all(ast, errors) end
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
  return spec, tree, ast
end

return M
