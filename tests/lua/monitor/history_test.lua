-- dca.monitor.history: a signal's history from the start, bounded however many samples come, evenly decimated.
local T = require "dca.testing"
local history = require "dca.monitor.history"
local suite = T.suite("monitor_history")

-- A million samples: never more than the bound, the first sample kept, the spacing even, the last ones recent.
suite:case("many_samples_stay_bounded_from_the_start", function()
  local h = history.new(1000)
  local most = 0
  for i = 0, 999999 do
    h:add(i * 0.001, { i, -i })
    if #h:rows() > most then most = #h:rows() end
  end
  local rows = h:rows()
  T.ok(most < 1000, "never more than the bound: " .. most)
  T.ok(#rows >= 500, "at least half the bound kept: " .. #rows)
  T.eq(rows[1][1], 0.0, "the run's first sample is kept")
  T.eq(rows[1][3], 0, "with its values")
  local step = rows[2][2] - rows[1][2]
  for i = 2, #rows do T.eq(rows[i][2] - rows[i - 1][2], step, "even spacing at row " .. i) end
  T.ok(rows[#rows][2] > 1000000 - 2 * step, "the last row is recent: sample " .. rows[#rows][2])
  T.eq(h.stride, step, "one row per stride")
end)

-- Below the bound, every sample is kept as given.
suite:case("few_samples_all_kept", function()
  local h = history.new(10)
  for i = 1, 9 do h:add(i, { i * 2 }) end
  T.eq(#h:rows(), 9)
  T.eq(h:rows()[9], { 9, 18 })
end)

return suite:run(...)
