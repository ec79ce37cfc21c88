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
-- value: nil, "dca graph: --root needs a value" / "dca graph: unknown option '--rot' (did you mean --root?)" /
-- "dca graph: unexpected argument 'x'" (one positional too many).
local distance = require("dca.lang.source").distance

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
    elseif a:sub(1, 1) == "-" then
      return nil, name .. ": unknown option '" .. a .. "'" .. M.did_you_mean(a, options)
    elseif o.n >= max then
      return nil, name .. ": unexpected argument '" .. a .. "'"
    else
      o.n = o.n + 1
      o[o.n] = a
    end
    i = i + 1
  end
  return o
end

--- " (did you mean --x?)" for `word` among the keys of `names` (at most two edits away, or a key it begins),
--- or "". Exported for the subcommands' own checks.
function M.did_you_mean(word, names)
  local close = {}
  for n in pairs(names) do
    if distance(word, n) <= math.min(2, math.max(1, #n // 3)) or (#word >= 3 and n:sub(1, #word) == word) then
      close[#close + 1] = n
    end
  end
  if #close == 0 then return "" end
  table.sort(close)
  return " (did you mean " .. table.concat(close, " or ") .. "?)"
end

--- Writes err and the usage's first line to stderr, and where the rest is. --> 2 (the exit code of bad usage)
function M.usage_error(err, usage)
  usage = tostring(usage or "")
  local first = usage:match("^[^\n]*") or ""
  local cmd = first:match("^usage: (dca %S+)")
  local more = usage:find("\n", 1, true) and " ..." or ""
  io.stderr:write(err, "\n", first, more, "\n")
  if cmd then io.stderr:write("(`", cmd, " --help`: the whole usage)\n") end
  return 2
end

return M
