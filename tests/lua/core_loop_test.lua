-- dca.core's loop and timers: core.loop(), core.after, core.every, errors in callbacks.
local T = require "dca.testing"
local core = require "dca.core"
local suite = T.suite("core_loop")

local loop = core.loop()

suite:case("loop_is_one_object_per_state", function()
  T.ok(core.loop() == loop)
  T.contains(tostring(loop), "dca.Loop")
end)

suite:case("after_fires_once_in_deadline_order", function()
  local order = {}
  core.after(0.02, function() order[#order + 1] = "b" end)
  core.after(0.001, function() order[#order + 1] = "a" end)
  core.after(0.04, function() order[#order + 1] = "c" end)
  T.ok(loop:run_until(function() return #order == 3 end, 10))
  T.eq(order, { "a", "b", "c" })
end)

suite:case("every_repeats_until_cancelled", function()
  local n = 0
  local t
  t = core.every(0.002, function(timer)
    n = n + 1
    T.ok(timer == t, "the callback gets its timer")
    if n == 5 then timer:cancel() end
  end)
  T.ok(t:active())
  T.ok(loop:run_until(function() return n == 5 end, 10))
  T.ok(not t:active())
  -- nothing fires after the cancel: the loop runs out of work
  loop:run()
  T.eq(n, 5)
  T.contains(tostring(t), "dca.Timer(every")
end)

suite:case("cancelled_after_never_fires", function()
  local fired = false
  local t = core.after(0.001, function() fired = true end)
  T.eq(t:cancel(), true)
  T.eq(t:cancel(), false)
  loop:run()
  T.eq(fired, false)
end)

suite:case("run_until_times_out_with_false", function()
  local t = core.after(5, function() end)
  T.eq(loop:run_until(function() return false end, 0.01), false)
  t:cancel()
end)

suite:case("stop_ends_run", function()
  local keep = core.every(0.001, function() end)
  core.after(0.005, function() loop:stop() end)
  loop:run()
  keep:cancel()
  T.ok(true)
end)

suite:case("error_in_callback_is_reported_and_the_loop_goes_on", function()
  local before = loop:errors()
  local after_error = false
  core.after(0, function() error("deliberate callback failure") end)
  core.after(0.002, function() after_error = true end)
  T.ok(loop:run_until(function() return after_error end, 10))
  local n, last = loop:errors()
  T.eq(n, before + 1)
  T.contains(last, "deliberate callback failure")
  T.contains(last, "stack traceback")
end)

suite:case("error_in_run_until_predicate_is_raised", function()
  local t = core.after(0.001, function() end)
  local err = T.raises(function() loop:run_until(function() error("bad predicate") end, 1) end)
  T.contains(err, "bad predicate")
  t:cancel()
end)

suite:case("bad_arguments_raise_lua_errors", function()
  T.contains(T.raises(core.after, -1, function() end), "seconds must be >= 0")
  T.contains(T.raises(core.every, 0, function() end), "period > 0")
  T.contains(T.raises(core.after, 1, "not a function"), "function expected")
end)

suite:case("to_be_closed_timer_cancels", function()
  local fired = false
  do
    local t <close> = core.after(0.001, function() fired = true end)
  end
  loop:run()
  T.eq(fired, false)
end)

return suite:run(...)
