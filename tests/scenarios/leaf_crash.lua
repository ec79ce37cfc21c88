-- A leaf crashes (SIGSEGV) mid-run: the group aborts its siblings LIFO and the run ends ABORTED naming it.
local S = require "dca.scenario"
local src = os.getenv("DCA_SOURCE_DIR") or "."
local sys = S.system(src .. "/scripts/systems/test_crash.dca")

S.step("up and running", function() sys:up() sys:run() end)

S.step("crashy dies by SIGSEGV after step1: ABORTED with its path and the signal", function()
  local out = sys:wait_outcome(5)
  S.eq(out.type, "aborted")
  S.eq(out.path, "main.work.crashy")
  S.contains(out.reason, "SIGSEGV")
  S.contains(out.reason, "h2")
end)

S.step("the siblings were stopped most recently started first: arm, then base", function()
  S.eq(sys:commands(" stop$"), { "main.work.arm stop", "main.work.base stop" })
  S.eq(sys:state("main.work.crashy"), "exited")
end)
return S.finish()
