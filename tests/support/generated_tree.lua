-- A generated supervision tree for the in-memory cluster (dca.supervisor.memory), the shape of the 1,000-leaf
-- benchmarks (tests/bench/supervisor_bench.lua, tests/monitor/big_system.lua): `groups` groups of `per` leaves
-- each on hosts h1..h3, under one root "main"; each group runs all its leaves concurrently, the root runs all
-- groups concurrently. With `chain`, each group also chains its leaves (l1 -> l2 -> ...) with one connection set.
--   local generated = dofile(src .. "/tests/support/generated_tree.lua")
--   local root = generated(100, 10, true)
local fake = require "dca.supervisor.memory"

return function(groups, per, chain)
  local children = {}
  for g = 1, groups do
    local leaves, names, conns = {}, {}, {}
    for l = 1, per do
      leaves[l] = fake.leaf("l" .. l, "Worker", "h" .. ((g + l) % 3 + 1))
      names[l] = "l" .. l
      if l > 1 then conns[#conns + 1] = { "l" .. (l - 1), "Out", "l" .. l, "In" } end
    end
    children[g] = fake.group("g" .. g, "G" .. g, "h" .. (g % 3 + 1), table.concat(names, " , "), leaves,
      chain and { fake.set("l1", "run", conns) } or nil)
  end
  local names = {}
  for g = 1, groups do names[g] = "g" .. g end
  return fake.root("main", "h1", table.concat(names, " , "), children)
end
