-- A reload fixes a group's expression between two runs; a broken edit is refused and the old one kept.
local S = require "dca.scenario"
local T = require "dca.testing"
local src = os.getenv("DCA_SOURCE_DIR") or "."
local tmp = T.tmpname(".dca")
local function write(text) local f = assert(io.open(tmp, "w")) f:write(text) f:close() end
local f = assert(io.open(src .. "/scripts/systems/test_reload.dca")) local original = f:read("a") f:close()
write(original)
local sys = S.system(tmp)

S.step("first run: the deadline wins, ABORTED", function()
  sys:up()
  sys:run()
  local out = sys:wait_outcome(5)
  S.eq(out.type, "aborted")
  S.eq(out.path, "main.task.deadline")
end)

S.step("a broken edit is refused with file:line:col and the old version kept", function()
  write((original:gsub("deadline # work", "deadline # # work")))
  local lines, err = sys:reload()
  S.eq(lines, nil)
  S.contains(err, tmp .. ":")
  S.ok(err:match(":%d+:%d+:"), "file:line:col in: " .. err)
end)

S.step("the fix is reported and takes effect at the next start", function()
  write((original:gsub("deadline # work", "work")))
  local lines = assert(sys:reload())
  S.eq(#lines, 1)
  S.contains(lines[1], "main.task (Task): event actions changed; takes effect at next start")
end)

S.step("second run: DONE", function()
  sys:run()
  local out = sys:wait_outcome(5)
  S.eq(out, { type = "done", value = "timeout" })
end)

T.cleanup()
return S.finish()
