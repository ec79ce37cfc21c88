-- Golden tests of the language's messages: each tests/lua/lang/golden/NAME.dca is parsed and checked, and the
-- full text printed for it (parse error, or every check error and the count line) must equal NAME.err
-- exactly. A first line "// golden: registry" checks against the fixed registry below; "// golden: root=X"
-- names the root. DCA_GOLDEN_UPDATE=1 rewrites the .err files (review the diff!).
local T = require "dca.testing"
local parser = require "dca.lang.parser"
local check = require "dca.lang.check"
local model = require "dca.lang.model"
local suite = T.suite("golden")

local dir = T.here() .. "/golden"

-- A small fixed registry in the shape of dca.core.types().
local registry = {
  ForceSensor = { inputs = {}, outputs = { { name = "Out1" }, { name = "Force" } }, params = {} },
  CompliantCtrl = { inputs = { { name = "In1" } }, outputs = { { name = "Out1" } }, params = {} },
  Puma560 = { inputs = { { name = "In1" } }, outputs = { { name = "Joints" } }, params = {} },
  HitDetector = { inputs = { { name = "In1" } }, outputs = {},
                  params = { { name = "threshold", type = "number", required = true } } },
  Gain = { inputs = { { name = "In" } }, outputs = { { name = "Out" } },
           params = { { name = "k", type = "number", required = true },
                      { name = "period", type = "number", required = false, default = "0" } } },
  XR4000Odometry = { inputs = {}, outputs = { { name = "Pose" } }, params = {} },
  Counter = { inputs = {}, outputs = { { name = "Count" } },
              params = { { name = "period", type = "number", required = true },
                         { name = "limit", type = "integer", required = false, default = "0" } } },
}

--- What the language tools print for `text` (exactly what `dca check --no-registry` prints, registry aside).
local function output(text, filename)
  local ast, err = parser.parse(text, filename)
  if not ast then return err .. "\n" end
  local opts = {}
  local directive = text:match("^// golden:([^\n]*)")
  if directive then
    if directive:find("registry", 1, true) then opts.types = registry end
    opts.root = directive:match("root=([%w_]+)")
  end
  local errors
  if ast.by_name[opts.root or "main"] then
    -- with a root, exactly what `dca check` does: dca.lang.model checks, binds the arguments and checks again
    local tree, errs = model.build(ast, opts)
    errors = tree and {} or errs
  else
    errors = check.check(ast, opts)
  end
  return check.format_all(ast, errors) .. "\n"
end

local names = T.list(dir, "%.dca$")
assert(#names > 0, "no golden files in " .. dir)

for _, file in ipairs(names) do
  local n = file:match("^(.*)%.dca$")
  suite:case(n, function()
    local got = output(T.read(dir .. "/" .. file), file)
    T.golden(dir .. "/" .. n .. ".err", got)
    T.ok(not got:find(": 0 errors\n", 1, true), "a golden input must produce errors")
  end)
end

return suite:run(...)
