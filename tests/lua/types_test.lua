-- core.types() and `dca types`: the controller registry's manifests, seen from Lua and the command line.
local T = require "dca.testing"
local core = require "dca.core"
local suite = T.suite("types")

suite:case("types_lists_every_builtin", function()
  local types = core.types()
  for _, name in ipairs { "Timer", "Deadline", "Constant", "Gain", "Sum", "Threshold", "Counter", "Crash" } do
    T.ok(types[name], "missing type " .. name)
  end
end)

suite:case("ports_have_name_type_and_size", function()
  local sum = core.types().Sum
  T.eq(#sum.inputs, 2)
  T.eq(sum.inputs[1], { name = "In1", type = "vectorx", size = 0, units = "" })
  T.eq(sum.outputs[1].name, "Out")
  local th = core.types().Threshold
  T.eq(th.inputs[1], { name = "In", type = "scalar", size = 1, units = "" })
  T.eq(#th.outputs, 0)
end)

suite:case("params_are_listed_in_order", function()
  local timer = core.types().Timer
  T.eq(#timer.params, 1)
  T.eq(timer.params[1].name, "seconds")
  T.eq(timer.params[1].required, true)
  local gain = core.types().Gain
  T.eq(gain.params[2].name, "period")
  T.eq(gain.params[2].default, "0")
  T.eq(core.types().Constant.params[2].variadic, true)
end)

-- A live parameter (docs/packages.md, "Live parameters"): Gain's k changes while it runs, its period does not.
suite:case("live_parameters_are_marked_in_core_types_and_dca_types", function()
  local gain = core.types().Gain
  T.eq(gain.params[1].live, true)
  T.eq(gain.params[2].live, false)
  T.dca("types Gain", 0, "param  k          number   the gain  (live)")
end)

suite:case("dca_types_prints_signatures_and_ports", function()
  T.dca("types", 0, "Gain(host, k, period=0)", "in     In1", "Timer(host, seconds)", "Constant(host, period, values...)")
end)

suite:case("types_declare_how_a_run_ends", function()
  -- dca check --verify reads these: a sensor never ends by itself, a threshold ends DONE, a Timer after its time
  T.ok(core.load_package("door"))  -- the door controllers are a package
  local types = core.types()
  T.eq({ types.Timer.ends, types.Timer.ends_after }, { "done", "seconds" })
  T.eq({ types.Deadline.ends, types.Deadline.ends_after }, { "aborted", "seconds" })
  T.eq(types.Constant.ends, "never")
  T.eq(types.Threshold.ends, "done")
  T.eq(types.ForceTorque.ends, "never")
  T.eq(types.ForceThreshold.ends, "done")
  T.eq(types.PressHandle.ends, "done or aborted")
  T.eq(types.VisualServoing.ends, "aborted")
  T.eq(types.Puma560Ctrl.ends, "never")
  for name, m in pairs(types) do
    local e = m.ends
    T.ok(e == nil or e == "never" or e == "done" or e == "aborted" or e == "done or aborted", name .. " ends " .. tostring(e))
  end
end)

suite:case("dca_types_prints_how_a_run_ends", function()
  T.dca("types Timer LaserSensor", 0, "ends   done, `seconds` seconds after each start", "ends   never")
  T.dca("types Counter", 0, "ends   done (never when limit is 0)")
  local nw = require("dca.core").types().Counter.never_when
  T.eq({ nw.param, nw.value }, { "limit", "0" })
end)

suite:case("dca_types_of_an_unknown_type_fails_listing_the_known", function()
  T.dca("types Gian", 1, "unknown controller type 'Gian'; types are: ", "Gain")
end)

suite:case("the_language_fallback_manifests_match_the_registry", function()
  -- dca.lang.check's Timer and Deadline, for a check without dca.core, take what the registry's take
  local check = require "dca.lang.check"
  for name, fallback in pairs(check.builtins) do
    local m = T.ok(core.types()[name], "the registry has " .. name)
    T.eq(#fallback.params, #m.params, name .. " parameters")
    for i, p in ipairs(fallback.params) do T.eq(p.type, m.params[i].type, name .. " parameter " .. i) end
    T.eq({ #fallback.inputs, #fallback.outputs }, { #m.inputs, #m.outputs }, name .. " ports")
    T.eq(fallback.ends, m.ends, name .. " ends")
  end
end)

return suite:run(...)
