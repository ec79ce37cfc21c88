-- `dca daemon` as a process: what it does to itself before it serves.
local T = require "dca.testing"
local suite = T.suite("daemon")

local fmt = string.format

--- The soft and hard "Max open files" of a running process.
local function descriptor_limits(pid)
  for line in io.lines("/proc/" .. pid .. "/limits") do
    local soft, hard = line:match("^Max open files%s+(%S+)%s+(%S+)")
    if soft then return soft, hard end
  end
end

-- At the common default of 1024 descriptors (or less) a daemon under many connections ran out.
suite:case("raises_its_soft_descriptor_limit_to_the_hard_one_and_says_so", function()
  local key = T.tmpfile(string.rep("5a", 32), ".key")
  os.execute("chmod 600 " .. key)
  local cmd = fmt("timeout 20 sh -c 'ulimit -Sn 256 && echo $$ && exec %s daemon --host fd --listen 127.0.0.1:0 "
                  .. "--key %s --state-dir none' 2>&1", T.exe, key)
  local p = assert(io.popen(cmd, "r"))
  local pid = assert(tonumber(p:read("l")), "the daemon's pid")
  local said, listening = nil, false
  for line in p:lines() do
    said = said or line:match("descriptors: (.*)$")
    if line:match("listening on") then listening = true break end
  end
  local soft, hard = descriptor_limits(pid)
  os.execute("kill -TERM " .. pid)
  p:close()
  os.remove(key)
  T.ok(listening, "the daemon started")
  T.eq(soft, hard, "soft limit of the running daemon")
  T.eq(said, fmt("soft limit %s (was 256, hard limit %s)", hard, hard))
end)

return suite:run(...)
