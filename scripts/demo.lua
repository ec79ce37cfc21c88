-- The demo driver (scripts/demo). Runs the most complete system that exists, and says which.
local core = require "dca.core"
io.write("dca ", core.version, "\n")
io.write("The door-opening demo is not built yet. What exists and runs now:\n")
io.write("  the dca executable with embedded Lua ", _VERSION, " and LPeg ", tostring(require("lpeg").version), "\n")
io.write("  Lua modules from ", core.lua_dir, "\n")
return 0
