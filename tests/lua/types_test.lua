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

suite:case("dca_types_prints_signatures_and_ports", function()
  T.dca("types", 0, "Gain(host, k, period=0)", "in     In1", "Timer(host, seconds)", "Constant(host, period, values...)")
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
  end
end)

return suite:run(...)
