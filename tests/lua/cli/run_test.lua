-- `dca run`: the options that go with --sim WORLD are refused without it, naming the rule.
local T = require "dca.testing"
local suite = T.suite("run")

local dca, src = T.exe, T.src

for _, c in ipairs({ { "jammed", "--jammed go with --sim WORLD" }, { "realtime", "--realtime goes with --sim WORLD" } }) do
  suite:case("run_" .. c[1] .. "_needs_sim", function()
    local out, rc = T.sh(dca .. " run " .. src .. "/scripts/systems/door_open.dca --" .. c[1])
    T.eq(rc, 2, "exit code")
    T.contains(out, c[2])
  end)
end

return suite:run(...)
