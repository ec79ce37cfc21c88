-- Parse + check time of a generated 1,000-instance .dca file (target < 100 ms), beside the baselines of the
-- same run: an empty Lua loop of the same iteration count, and one raw LPeg pass over the same text.
--   dca lua tests/bench/parse_bench.lua [iterations]
local parser = require "dca.lang.parser"
local check = require "dca.lang.check"
local model = require "dca.lang.model"
local lpeg = require "lpeg"

local ITER = tonumber((...)) or 30
local clock = os.clock

-- 100 groups of 9 leaves (with connections and an expression), and main instantiating the 100 groups:
-- 1,000 instances in all.
local function generate()
  local out = {}
  local function add(s) out[#out + 1] = s end
  for g = 1, 100 do
    add(string.format("process Group%d(h1, h2) {\n  host { h1 }\n  instantiated_processes {\n", g))
    for i = 1, 9 do
      add(string.format("    leaf%d instof Ctrl%d(%s, %d, \"mode\");\n", i, i, i % 2 == 0 and "h1" or "h2", i))
    end
    add("  }\n  external_io { Out = leaf9, Out; }\n")
    for i = 1, 8 do
      add(string.format("  internal_connections(leaf%d, lbl1) { leaf%d, Out -> leaf%d, In; }\n", i, i, i + 1))
    end
    add("  internal_event_actions {\n    leaf1[lbl1] # (leaf2[lbl1] , leaf3[lbl1] ; leaf4[lbl1] : leaf5[lbl1])" ..
        " ; (leaf6[lbl1] , leaf7[lbl1] , leaf8[lbl1]) # leaf9\n  }\n}\n")
  end
  add("process main() {\n  instantiated_processes {\n")
  for g = 1, 100 do add(string.format("    g%d instof Group%d(\"host%d\", \"host%d\");\n", g, g, g % 3, (g + 1) % 3)) end
  add("  }\n  internal_event_actions {\n    ")
  local names = {}
  for g = 1, 100 do names[g] = "g" .. g end
  add(table.concat(names, " , "))
  add("\n  }\n}\n")
  return table.concat(out)
end

local text = generate()
-- sanity: it is a correct 1,000-instance system
do
  local ast = assert(parser.parse(text, "gen.dca"))
  local tree, errs = model.build(ast)
  if not tree then error(check.format_all(ast, errs)) end
  assert(model.summary(tree).instances == 1000, "1,000 instances")
end

local function result(bench, variant, times, extra)
  table.sort(times)
  local function pct(p) return times[math.max(1, math.ceil(#times * p))] * 1e6 end
  io.write(string.format("RESULT bench=%s variant=%s n=%d p50_us=%.1f p99_us=%.1f p999_us=%.1f max_us=%.1f%s\n",
                         bench, variant, #times, pct(0.5), pct(0.99), pct(0.999), times[#times] * 1e6, extra or ""))
  io.flush()
end

local function timed(fn)
  local times = {}
  for _ = 1, ITER do
    local t0 = clock()
    fn()
    times[#times + 1] = clock() - t0
  end
  return times
end

local scan = (lpeg.P(1))^0
io.stderr:write(string.format("parse_bench: %d bytes, 1,000 instances, %d iterations\n", #text, ITER))
for round = 1, 2 do
  result("lua_empty_loop", "n" .. ITER, timed(function() end))
  result("lpeg_raw_scan", "1000_instances", timed(function() lpeg.match(scan, text) end), " bytes=" .. #text)
  result("dca_parse", "1000_instances", timed(function() assert(parser.parse(text, "gen.dca")) end))
  result("dca_parse_check", "1000_instances", timed(function()
    local ast = assert(parser.parse(text, "gen.dca"))
    assert(#check.check(ast) == 0)
  end), " round=" .. round)
  result("dca_parse_check_model", "1000_instances", timed(function()
    local ast = assert(parser.parse(text, "gen.dca"))
    assert(model.build(ast))
  end))
end
