-- The tidy-up task with a Timer: A and B are placed, C is never found, the timeout ends the task.
local S = require "dca.scenario"
local src = os.getenv("DCA_SOURCE_DIR") or "."
local sys = S.system(src .. "/scripts/systems/test_tidy_up.dca")

S.step("up and running", function() sys:up() sys:run() end)

S.step("A is found at 1 s and placed with its value", function()
  sys:wait_state("main.tidy.PlaceA", "running", 1.5)
  sys:wait_state("main.tidy.PlaceA", "done", 1)
end)

S.step("B is found and placed", function() sys:wait_state("main.tidy.PlaceB", "done", 2) end)

S.step("the Timeout ends the task DONE \"timeout\" at 5 s and aborts the search for C", function()
  local out = sys:wait_outcome(10)
  S.eq(out, { type = "done", value = "timeout" })
  if sys.backend == "memory" then S.eq(sys:now(), 5, "simulated time") end
  S.eq(sys:commands("FindObjectC stop"), { "main.tidy.FindObjectC stop" })
  S.eq(sys:commands("PlaceC run"), {}, "PlaceC never ran")
end)
return S.finish()
