-- The second opinion: spin (Promela, written from SEMANTICS.md by dca.verify.promela, not from dca.algebra)
-- must reach exactly the verdicts dca check --verify reaches: every end (DONE with which operand's value,
-- ABORTED by which operand's abort or fault), every stuck state (with faults off: spin's invalid end states)
-- and every violated property; on the paper's systems and on a few hundred generated expressions.
local T = require "dca.testing"
local load = require "dca.load"
local algebra = require "dca.algebra"
local verify = require "dca.verify"
local props = require "dca.verify.props"
local promela = require "dca.verify.promela"
local suite = T.suite("promela")

local here = T.here()
local gen = dofile(T.src .. "/tests/support/verify_gen.lua")

local function have_spin()
  local _, rc = T.sh("command -v spin && command -v cc")
  return rc == 0
end

-- Runs spin on the items { key, expr, operands, props, r, r_nofaults } (dca's results with faults and
-- without) and compares the verdicts.
local function agree_batch(items)
  local model = promela.model(items)
  local dir = T.tmpdir()
  local reached, out = promela.spin(model, dir)
  T.sh("rm -rf '" .. dir .. "'")
  T.ok(reached, out)
  local bad = {}
  local function compare(key, r, faults)
    local want, got = promela.verdicts(r), reached[key] or {}
    if faults then want.stuck = nil end  -- with faults something can always happen: spin is never stuck
    for k in pairs(want) do if not got[k] then bad[#bad + 1] = key .. ": dca " .. k .. ", spin not" end end
    for k in pairs(got) do if not want[k] then bad[#bad + 1] = key .. ": spin " .. k .. ", dca not" end end
  end
  for _, it in ipairs(items) do
    compare(it.key, it.r, true)
    compare(it.key .. ":nofaults", it.r_nofaults, false)
  end
  T.eq(bad, {}, "verdicts that differ")
  return #items
end

-- The items in batches of 100 expressions (spin's line numbers are 16-bit: a model stays under 32,767 lines).
local function agree(items)
  local n = 0
  for first = 1, #items, 100 do
    n = n + agree_batch(table.move(items, first, math.min(first + 99, #items), 1, {}))
  end
  return n
end

local SYSTEMS = { T.src .. "/scripts/systems/door_open.dca", T.src .. "/scripts/systems/tidy_up.dca",
                  T.src .. "/scripts/systems/compliant_motion.dca", here .. "/systems/door_paper.dca",
                  here .. "/systems/door_props.dca" }

suite:case("spin_agrees_on_the_paper_systems", function()
  T.ok(have_spin(), "spin and cc are installed (scripts/setup installs spin)")
  local items = {}
  for _, file in ipairs(SYSTEMS) do
    local ast, tree = load.file(file)
    T.ok(ast, tree)
    local with = assert(verify.system(tree, { ast = ast, faults = true }))
    local without = assert(verify.system(tree, { ast = ast, faults = false }))
    for i, r in ipairs(with.groups) do
      local ps = {}
      for _, p in ipairs(r.props) do if not p.outcome then ps[#ps + 1] = p.prop end end
      items[#items + 1] = { key = file:match("[^/]+$") .. ":" .. r.path, expr = r.node.process.actions.expr,
                            operands = r.operands, props = ps, r = r, r_nofaults = without.groups[i] }
    end
  end
  agree(items)
end)

-- (60 under the sanitizers: the work is Lua and spin's C, which the sanitizer build does not instrument)
suite:case("spin_agrees_on_300_generated_expressions_with_and_without_faults", function()
  T.ok(have_spin(), "spin and cc are installed (scripts/setup installs spin)")
  local count = T.sanitized and 60 or 300
  local seed = 17
  local function rnd(n) seed = (seed * 1103515245 + 12345) % 2147483648 return seed % n + 1 end
  local items = {}
  for i = 1, count do
    local text, ends, ptext = gen.expression(rnd, 2 + rnd(6))
    local expr = assert(algebra.parse(text))
    local list = props.parse(ptext, 1)
    local operands, without = {}, {}
    for _, name in ipairs(expr.names) do
      operands[name] = verify.leaf_events(name, ends[name], true)
      without[name] = verify.leaf_events(name, ends[name], false)
    end
    items[#items + 1] = { key = "g" .. i, expr = expr, operands = operands, props = list,
                          r = verify.expression(expr, operands, list), r_nofaults = verify.expression(expr, without, list) }
  end
  T.eq(agree(items), count)
end)

return suite:run(...)
