-- dca.launch.start.sequence: the named steps run in order, a waiting step suspends the sequence until its
-- callback, and the first failure ends it naming the step (the steps themselves run in the real-process
-- tests: tests/lua/cli/supervisor_cli_test.lua, tests/scenarios).
local T = require "dca.testing"
local start = require "dca.launch.start"
local suite = T.suite("start")

-- Replaces the steps named in `fakes` for the duration of fn.
local function with_steps(fakes, fn)
  local saved = {}
  for name, f in pairs(fakes) do saved[name], start[name] = start[name], f end
  local ok, err = pcall(fn)
  for name, f in pairs(saved) do start[name] = f end
  if not ok then error(err, 0) end
end

suite:case("steps_run_in_order_and_a_waiting_step_suspends_the_sequence", function()
  local log, resume = {}, nil
  with_steps({
    hosts = function() log[#log + 1] = "hosts" return true end,
    config = function() log[#log + 1] = "config" return true end,
    world = function(_, cb) log[#log + 1] = "world asked" resume = cb end,
  }, function()
    local result
    start.sequence({}, { "hosts", "world", "config" }, function(...) result = table.pack(...) end)
    T.eq(log, { "hosts", "world asked" })
    T.eq(result, nil, "not done while the world is awaited")
    resume(true)
    T.eq(log, { "hosts", "world asked", "config" })
    T.eq(result[1], true)
  end)
end)

suite:case("the_first_failure_ends_the_sequence_naming_its_step", function()
  local ran = {}
  with_steps({
    hosts = function() ran.hosts = true return true end,
    config = function() ran.config = true return nil, "bad defaults", "file" end,
    sim_clock = function(_, cb) ran.sim_clock = true cb(true) end,
  }, function()
    local ok, err, step, kind
    start.sequence({}, { "hosts", "config", "sim_clock" }, function(...) ok, err, step, kind = ... end)
    T.eq({ ok, err, step, kind }, { nil, "bad defaults", "config", "file" })
    T.eq(ran, { hosts = true, config = true }, "nothing after the failure")
  end)
end)

return suite:run(...)
