-- core.types() and `dca types`: the controller registry's manifests, seen from Lua and the command line.
local T = require "dca.testing"
local core = require "dca.core"
local suite = T.suite("types")

local dca = os.getenv("DCA_EXE") or "dca"

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
  local out, rc = T.sh(dca .. " types")
  T.eq(rc, 0)
  T.contains(out, "Gain(host, k, period=0)")
  T.contains(out, "in     In1")
  T.contains(out, "Timer(host, seconds)")
  T.contains(out, "Constant(host, period, values...)")
end)

suite:case("dca_types_of_an_unknown_type_fails_listing_the_known", function()
  local out, rc = T.sh(dca .. " types Gian")
  T.eq(rc, 1)
  T.contains(out, "unknown controller type 'Gian'; types are: ")
  T.contains(out, "Gain")
end)

return suite:run(...)
