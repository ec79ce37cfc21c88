-- dca.cli.args: the one argument parser of the dca subcommands (lua/dca/cli/*.lua).
--
--   local args = require "dca.cli.args"
--   local o, err = args.parse(argv, "dca graph", {
--     ["--root"] = "value", ["-o"] = "value:out", ["--svg"] = "flag", ["--no-registry"] = "flag",
--   })
--   if not o then return args.usage_error(err, M.usage) end
--   -- o.root, o.out, o.svg, o.no_registry; the positional arguments in o[1], o[2], ... (o.n of them)
--
-- An option is "KIND" or "KIND:key": KIND is flag (true when given), value (the next argument), number
-- (the next argument as a number) or list (the next argument, appended each time the option is given);
-- key defaults to the spelling without leading dashes, '-' turned into '_'. The positional arguments are
-- at most `max` (default 1). Anything else starting with '-' is an error, as is an option missing its
-- value: nil, "dca graph: --root needs a value" / "dca graph: unexpected argument '--x'".
local M = {}

local function key_of(spelling, kind)
  local k = kind:match(":(.+)$")
  return k or (spelling:gsub("^%-%-?", ""):gsub("%-", "_"))
end

--- Parses argv (a table with .n or a sequence) by the options table. --> o | nil, error text
function M.parse(argv, name, options, max)
  max = max or 1
  local o, n, i = { n = 0 }, argv.n or #argv, 1
  while i <= n do
    local a = argv[i]
    local spec = options[a]
    if spec then
      local kind, key = spec:match("^(%a+)"), key_of(a, spec)
      if kind == "flag" then
        o[key] = true
      else
        i = i + 1
        local v = argv[i]
        if v == nil then return nil, name .. ": " .. a .. " needs a value" end
        if kind == "number" then
          v = tonumber(v)
          if not v then return nil, name .. ": " .. a .. " needs a number" end
        end
        if kind == "list" then o[key] = o[key] or {}; table.insert(o[key], v) else o[key] = v end
      end
    elseif a:sub(1, 1) == "-" or o.n >= max then
      return nil, name .. ": unexpected argument '" .. a .. "'"
    else
      o.n = o.n + 1
      o[o.n] = a
    end
    i = i + 1
  end
  return o
end

--- Writes err and the usage to stderr. --> 2 (the exit code of bad usage)
function M.usage_error(err, usage)
  io.stderr:write(err, "\n", usage, "\n")
  return 2
end

return M
