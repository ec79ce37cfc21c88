-- dca.supervisor.failover: which host a child restarts on after its host was lost, and a sub-group's spec moved.
local T, failover = require "dca.testing", require "dca.supervisor.failover"
local suite = T.suite("supervisor_failover")

local group = { host = "h2", hosts = { "h2", "h2b", "h2c" } }

suite:case("a_leaf_takes_its_own_standby_hosts_in_order_then_none", function()
  local leaf = { kind = "leaf", name = "cam", host = "h1", standby = { "h1b", "h1c" } }
  local list = failover.hosts(leaf, group)
  T.eq(list, { "h1", "h1b", "h1c" })
  T.eq(failover.next_host(list, "h1"), "h1b")
  T.eq(failover.next_host(list, "h1b"), "h1c")
  T.eq(failover.next_host(list, "h1c"), nil)
  T.eq(failover.next_host(list, "elsewhere"), nil)
end)

suite:case("a_leaf_on_its_groups_host_takes_the_groups_standby_hosts_another_leaf_none", function()
  T.eq(failover.hosts({ kind = "leaf", host = "h2" }, group), { "h2", "h2b", "h2c" })
  T.eq(failover.hosts({ kind = "leaf", host = "h9" }, group), nil)
  T.eq(failover.hosts({ kind = "leaf", host = "h2" }, { host = "h2", hosts = { "h2" } }), nil)
end)

suite:case("a_sub_group_takes_its_host_list_and_moves_with_what_ran_on_the_lost_host", function()
  local sub = { host = "v", hosts = { "v", "v2" }, children = {
    { kind = "leaf", name = "cam", host = "v" },
    { kind = "leaf", name = "arm", host = "m" },
    { kind = "leaf", name = "track", host = "v", standby = { "v3", "v4" } },
    { kind = "group", name = "inner", host = "v", spec = { host = "v", hosts = { "v" }, children = {
      { kind = "leaf", name = "x", host = "v" } } } },
  } }
  T.eq(failover.hosts({ kind = "group", spec = sub }, group), { "v", "v2" })
  local moved = failover.moved(sub, "v", "v2")
  T.eq(moved.host, "v2")
  T.eq(moved.hosts, { "v", "v2" }, "its list stays: the order of the next failover")
  T.eq(moved.children[1].host, "v2")
  T.eq(moved.children[2].host, "m", "a leaf on another host stays there")
  T.eq(moved.children[3].host, "v3", "a leaf with standby hosts of its own: the first of them")
  T.eq(moved.children[4].host, "v2")
  T.eq(moved.children[4].spec.children[1].host, "v2")
  T.eq(sub.children[1].host, "v", "the original is untouched")
end)

return suite:run(...)
