-- A leaf crashes (SIGSEGV) mid-run: the group aborts its siblings LIFO and the run ends ABORTED naming it.
local S = require "dca.scenario"
local src = os.getenv("DCA_SOURCE_DIR") or "."
local sys = S.system(src .. "/scripts/systems/test_crash.dca")

S.step("up and running", function() sys:up() sys:run() end)

-- Under a shared placement (`dca scenario --placement group|host`) crashy shares its node with arm (both on
-- h2): the crash ends both, each reported with its path, host and the signal, crashy first (the node noted
-- whose code crashed); base (h1) is stopped.
local shared = sys.backend == "real" and (S.placement or "process") ~= "process"

S.step("crashy dies by SIGSEGV after step1: ABORTED with its path and the signal", function()
  local out = sys:wait_outcome(5)
  S.eq(out.type, "aborted")
  S.eq(out.path, "main.work.crashy")  -- (shared: the node's crash note names it, so it comes first)
  if shared then S.contains(out.reason, "it crashed in main.work.crashy") end
  S.contains(out.reason, "SIGSEGV")
  S.contains(out.reason, "h2")
end)

if shared then
  S.step("its shared node's crash ended arm and crashy, each named with the signal; base was stopped", function()
    for _, leaf in ipairs({ "main.work.arm", "main.work.crashy" }) do
      S.eq(sys:state(leaf), "exited")
      local said
      for _, l in ipairs(sys:transitions()) do
        if l:find(leaf .. ": exited: killed by SIGSEGV on host h2 (shared node", 1, true) == 1 then said = l end
      end
      S.ok(said, leaf .. "'s exit is reported with its path, the signal and its host")
    end
    S.eq(sys:commands(" stop$"), { "main.work.base stop" })
  end)
  return S.finish()
end

S.step("the siblings were stopped most recently started first: arm, then base", function()
  S.eq(sys:commands(" stop$"), { "main.work.arm stop", "main.work.base stop" })
  S.eq(sys:state("main.work.crashy"), "exited")
end)
return S.finish()
