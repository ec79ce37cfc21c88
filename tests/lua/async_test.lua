-- dca.async: a join answers once, after every callback it made (or at the first failure when asked to), a list
-- is worked through in order, and a reply reads as a success or a reason.
local T = require "dca.testing"
local async = require "dca.async"
local suite = T.suite("async")

-- A callback that records its calls.
local function recorder()
  local calls = {}
  return calls, function(...) calls[#calls + 1] = table.pack(...) end
end

suite:case("a_join_answers_once_after_every_callback_and_its_close", function()
  local calls, cb = recorder()
  local j = async.join(cb)
  local a, b = j.add(), j.add()
  a(true)
  j.close()
  T.eq(#calls, 0, "b is still out")
  b(true)
  b(true)
  T.eq(#calls, 1)
  T.eq(calls[1][1], true)
  T.eq(j.over(), true)
end)

suite:case("an_empty_join_answers_at_its_close", function()
  local calls, cb = recorder()
  local j = async.join(cb)
  T.eq(#calls, 0)
  j.close()
  T.eq(#calls, 1)
  T.eq(calls[1][1], true)
end)

suite:case("a_callback_called_before_the_close_does_not_end_the_join", function()
  local calls, cb = recorder()
  local j = async.join(cb)
  j.add()(true)
  T.eq(#calls, 0, "not before the close")
  j.close()
  T.eq(#calls, 1)
end)

suite:case("a_join_waits_for_all_then_gives_the_first_failure", function()
  local calls, cb = recorder()
  local j = async.join(cb)
  local a, b, c = j.add(), j.add(), j.add()
  j.close()
  b(nil, "b failed")
  a(nil, "a failed")
  T.eq(#calls, 0, "c is still out")
  c(true)
  T.eq(#calls, 1)
  T.eq({ calls[1][1], calls[1][2] }, { nil, "b failed" })
end)

suite:case("a_fail_fast_join_answers_at_the_first_failure_and_never_again", function()
  local calls, cb = recorder()
  local j = async.join(cb, true)
  local a, b = j.add(), j.add()
  j.close()
  a(nil, "a failed")
  T.eq(#calls, 1)
  T.eq({ calls[1][1], calls[1][2] }, { nil, "a failed" })
  T.eq(j.over(), true)
  b(true)
  T.eq(#calls, 1)
end)

suite:case("each_in_order_goes_on_only_when_told", function()
  local seen, nexts, finished = {}, {}, false
  async.each_in_order({ "a", "b", "c" }, function(item, i, next)
    seen[#seen + 1] = item .. i
    nexts[#nexts + 1] = next
  end, function() finished = true end)
  T.eq(seen, { "a1" })
  nexts[1]()
  T.eq(seen, { "a1", "b2" })
  nexts[2]()
  nexts[3]()
  T.eq(seen, { "a1", "b2", "c3" })
  T.eq(finished, true)
end)

suite:case("each_in_order_stops_where_next_is_not_called", function()
  local seen, finished = {}, false
  async.each_in_order({ 1, 2, 3 }, function(item, _, next)
    seen[#seen + 1] = item
    if item < 2 then next() end
  end, function() finished = true end)
  T.eq(seen, { 1, 2 })
  T.eq(finished, false)
  local empty = false
  async.each_in_order({}, function() error("not called") end, function() empty = true end)
  T.eq(empty, true)
end)

suite:case("outcome_reads_a_reply_as_success_or_reason", function()
  local ok = { type = "ok", value = 3 }
  T.eq(async.outcome(ok), ok)
  T.eq({ async.outcome({ type = "error", reason = "no such set" }) }, { nil, "no such set" })
  T.eq({ async.outcome(nil, "timed out") }, { nil, "timed out" })
  T.eq({ async.outcome(nil, nil) }, { nil, "no answer" }, "a reason, never nil or \"nil\"")
  T.eq({ async.outcome({ type = "error" }) }, { nil, "an error reply without a reason" })
end)

return suite:run(...)
