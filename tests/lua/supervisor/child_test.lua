-- dca.supervisor.child: a child's state changes only along the transitions its table allows, and its restart
-- record is one field that is gone once nothing in it is set.
local T = require "dca.testing"
local child = require "dca.supervisor.child"
local suite = T.suite("supervisor.child")

local function leaf() return child.new({ name = "hit", path = "main.hit", kind = "leaf", host = "h1" }) end

suite:case("a_child_starts_new_and_follows_the_start_protocol", function()
  local ch = leaf()
  T.eq(ch.state, "new")
  for _, s in ipairs({ "starting", "inactive", "running", "done", "running", "stopping", "inactive", "gone" }) do
    child.set(ch, s)
    T.eq(ch.state, s)
  end
end)

suite:case("a_transition_the_table_does_not_allow_is_refused_naming_path_and_states", function()
  local ch = leaf()
  local ok, err = pcall(child.set, ch, "running")
  T.eq(ok, false)
  T.contains(err, "main.hit: no transition from new to running")
  T.eq(ch.state, "new", "the state is unchanged")
  ok, err = pcall(child.set, ch, "sleeping")
  T.eq(ok, false)
  T.contains(err, "main.hit: no state 'sleeping'")
end)

suite:case("every_state_is_declared_and_reached_from_somewhere", function()
  for to, from in pairs(child.FROM) do
    T.ok(child.STATES[to], "state " .. to .. " declared")
    for s in pairs(from) do T.ok(child.STATES[s], to .. " from " .. s .. ": declared") end
  end
  for s in pairs(child.STATES) do T.ok(s == "new" or child.FROM[s], "state " .. s .. " can be entered") end
end)

suite:case("the_restart_record_is_one_field_dropped_when_empty", function()
  local ch = leaf()
  T.eq(ch.restart, nil)
  child.mark(ch, { replacing = true, policy = true })
  T.eq(child.restart(ch, "replacing"), true)
  child.unmark(ch, "replacing")
  T.eq(ch.restart, { policy = true })
  child.unmark(ch, "policy", "pending")
  T.eq(ch.restart, nil)
  T.eq(child.restart(ch, "policy"), nil)
end)

return suite:run(...)
