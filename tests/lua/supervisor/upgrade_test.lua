-- dca.supervisor.upgrade, its pure parts: the plan (which hosts run leaves of the package, which leaves) and the
-- transition lines that fail a host being rolled. The roll itself, with daemons: tests/lua/launch/upgrade_test.lua.
local T = require "dca.testing"
local upgrade = require "dca.supervisor.upgrade"
local suite = T.suite("supervisor.upgrade")

local function leaf(path, host, package) return { kind = "leaf", name = path:match("[^.]+$"), path = path, host = host,
                                                  package = package, system_dir = "/sys" } end
local function group(path, children)
  return { kind = "group", name = path:match("[^.]+$"), spec = { path = path, children = children } }
end

-- main: r1 (h1: src, sc of pkg, sink), r2 (h2: sc of pkg, a nested group arm with a leaf of pkg on h3), gain
-- of another package on h1.
local SUP = { path = "main", spec = { path = "main", children = {
  group("main.r1", { leaf("main.r1.src", "h1"), leaf("main.r1.sc", "h1", "pkg"), leaf("main.r1.sink", "h1") }),
  group("main.r2", { leaf("main.r2.sc", "h2", "pkg"), group("main.r2.arm", { leaf("main.r2.arm.pd", "h3", "pkg") }) }),
  leaf("main.gain", "h1", "other"),
} } }

suite:case("the_plan_is_every_host_running_a_leaf_of_the_package_with_those_leaves", function()
  local plan = upgrade.plan(SUP, "pkg")
  T.eq(plan.hosts, { "h1", "h2", "h3" })
  T.eq(plan.leaves, { h1 = { "main.r1.sc" }, h2 = { "main.r2.sc" }, h3 = { "main.r2.arm.pd" } })
  T.eq(plan.system_dir, "/sys")
  local none, err = upgrade.plan(SUP, "door")
  T.eq(none, nil)
  T.eq(err, "no leaf of main uses package 'door' (packages used: other, pkg)")
end)

suite:case("a_standby_host_of_a_leaf_of_the_package_gets_the_file_and_is_never_the_canary", function()
  local sb = leaf("main.r1.sc", "h1", "pkg")
  sb.standby = { "h4", "h2" }  -- h2 runs a leaf of it anyway
  local sup = { path = "main", spec = { path = "main", children = { sb, leaf("main.r2.sc", "h2", "pkg") } } }
  local plan = upgrade.plan(sup, "pkg")
  T.eq(plan.hosts, { "h1", "h2", "h4" })
  T.eq(plan.leaves.h4, {})
  T.eq(plan.standby, { h4 = true })
  local err
  upgrade.run(setmetatable({ rt = { daemon = function() end } }, { __index = sup }), { name = "pkg", data = "x",
    canary = "h4" }, function(_, e) err = e end)
  T.eq(err, "upgrade pkg: the canary h4 runs no leaf of it (hosts that do: h1, h2)")
end)

suite:case("a_leaf_of_the_canarys_groups_that_ends_or_a_group_above_that_gives_up_fails_it", function()
  local u = {}
  upgrade.watch(u, SUP, { "main.r1.sc" })
  local fails = {
    "main.r1.sc: exited: killed by SIGABRT on host h1",
    "main.r1.sink: exited: killed by SIGSEGV on host h1",   -- a sibling the new code feeds
    "main.r1.src: aborted: stalled",
    "main.r1: aborted (main.r1.sc: restart intensity 3 in 60 s exceeded)",
    "main.r1: escalated: restart intensity 3 in 60 s exceeded",
    "main.r1: lost: host h1 lost",
    "main: aborted (main.r1: ...)",
  }
  for _, l in ipairs(fails) do T.eq(upgrade.failure(u, l), l) end
  for _, l in ipairs({ "main.r1.sc: restarting", "main.r1.sc: restarted (pid 42)", "main.r1.sc: running",
                       "main.r2.sc: exited: killed by SIGSEGV on host h2",  -- another host's: not the canary's
                       "main.gain: exited: killed by SIGSEGV on host h1", -- not in the canary's groups
                       "main.r1: one_for_one after sc killed by SIGABRT on host h1: restarting sc (1/3 in 60 s)",
                       "upgrade pkg: h1: failed: main.r1.sc: exited" }) do
    T.eq(upgrade.failure(u, l), nil, l)
  end
  -- nested: a leaf two levels down watches its group and both above
  upgrade.watch(u, SUP, { "main.r2.arm.pd" })
  T.eq(u.watched_parents, { ["main.r2.arm"] = true })
  T.eq(u.watched_groups, { ["main.r2.arm"] = true, ["main.r2"] = true, main = true })
  T.ok(upgrade.failure(u, "main.r2: escalated: x"))
  T.eq(upgrade.failure(u, "main.r2.sc: exited: x"), nil)
end)

suite:case("a_system_without_daemons_or_a_canary_without_the_package_is_refused_before_anything_changes", function()
  local asked = 0
  local rt = { daemon = function() asked = asked + 1 end }
  local ok, err
  upgrade.run(setmetatable({ rt = {} }, { __index = SUP }), { name = "pkg", data = "x" },
    function(o, e) ok, err = o, e end)
  T.eq(ok, nil)
  T.eq(err, "upgrade: the supervisor's runtime reaches no daemons (a real run only)")
  -- (shared nodes, --placement group|host, are not refused: their leaves move to processes of their own)
  local sup = setmetatable({ placement = "group", rt = rt }, { __index = SUP })
  upgrade.run(sup, { name = "pkg", data = "x", canary = "h9" }, function(o, e) ok, err = o, e end)
  T.eq(err, "upgrade pkg: the canary h9 runs no leaf of it (hosts that do: h1, h2, h3)")
  T.eq(asked, 0, "no daemon asked")
end)

return suite:run(...)
