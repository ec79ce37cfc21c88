-- `dca scenario [--backend memory] FILE.lua`: runs a scripted test scenario (see dca.scenario) and exits 0
-- when every step passed, 1 when one failed, 2 on bad usage.
local scenario = require "dca.scenario"
local args_mod = require "dca.cli.args"

local USAGE = [[usage: dca scenario [--backend memory|real] [--placement process|group|host] [--seed N]
                    [--trace FILE] FILE.lua

Runs the scenario in FILE.lua: it starts systems, drives them (events, faults, reloads), waits with timeouts
and asserts; each step prints one line (ok/FAIL, with the system's time). Exit code 0 when every step passed.
  --backend memory   the supervisor tree in memory with simulated time and the test controllers' behaviour
  --backend real     local daemons on loopback, real nodes and supervisors (wall-clock time)
  --placement P      with --backend real: where the leaves run (`dca run --placement`; default process)
  --seed N           the world's seed for the systems in simulated time (default: the scenario's own)
  --trace FILE       the trace of the (first) system in simulated time, as `dca run --trace` writes it; without
                     it one is written to a temporary file, kept and named only when the scenario fails]]

local function main(argv)
  local o, perr = args_mod.parse(argv, "dca scenario", { ["--backend"] = "value", ["--placement"] = "value",
                                                          ["--seed"] = "number", ["--trace"] = "value" })
  if not o then return args_mod.usage_error(perr, USAGE) end
  local file = o[1]
  if o.backend then
    if o.backend ~= "memory" and o.backend ~= "real" then
      io.stderr:write("dca scenario: unknown backend '", tostring(o.backend), "' (memory, real)\n")
      return 2
    end
    scenario.backend = o.backend
  end
  if o.placement then
    if not require("dca.cli.run").PLACEMENTS[o.placement] then
      io.stderr:write("dca scenario: unknown placement '", tostring(o.placement), "' (process, group, host)\n")
      return 2
    end
    scenario.placement = o.placement
  end
  if not file then io.stderr:write(USAGE, "\n") return 2 end
  if o.seed and math.type(o.seed) ~= "integer" then io.stderr:write("dca scenario: --seed needs an integer\n") return 2 end
  scenario.seed, scenario.trace = o.seed, o.trace
  scenario.argv = { file = file, backend = o.backend, placement = o.placement }
  local chunk, err = loadfile(file)
  if not chunk then io.stderr:write("dca scenario: ", err, "\n") return 2 end
  scenario.reset()
  local ok, res = xpcall(chunk, debug.traceback, file)
  if not ok then
    print("FAIL " .. tostring(res))
    return 1
  end
  if type(res) == "number" then return res end
  return scenario.finish()
end

return { summary = "run a scripted test scenario (start a system, inject events and faults, assert)",
         usage = USAGE, main = main }
