-- The embedded interpreter: lpeg, dca modules, and how `dca lua` reports errors.
local T = require "dca.testing"
local suite = T.suite("embed")

local dca = os.getenv("DCA_EXE") or "dca"

local function tmpfile(text) return T.tmpfile(text, ".lua") end

suite:case("lpeg_loads_and_matches", function()
  local lpeg = require "lpeg"
  local number = lpeg.C(lpeg.R("09") ^ 1) / tonumber
  T.eq(lpeg.match(number, "1234abc"), 1234)
end)

suite:case("dca_core_is_preloaded", function()
  local core = require "dca.core"
  T.ok(type(core.version) == "string" and core.version:match("^%d+%.%d+%.%d+$"), "core.version")
end)

suite:case("error_in_a_chunk_gives_file_line_and_nonzero_exit", function()
  -- run from its folder: Lua shortens a chunk name longer than 60 characters to "...<its end>"
  local dir = T.tmpdir()
  T.write(dir .. "/failing.lua", "local x = 1\nerror('deliberate failure')\n")
  local out, rc = T.sh("cd '" .. dir .. "' && " .. dca .. " lua failing.lua")
  T.eq(rc, 1, "exit code")
  T.contains(out, "failing.lua:2: deliberate failure")
  T.contains(out, "stack traceback")
end)

suite:case("chunk_result_is_the_exit_code", function()
  local path = tmpfile("return 3\n")
  local _, rc = T.sh(dca .. " lua " .. path)
  os.remove(path)
  T.eq(rc, 3)
end)

return suite:run(...)
