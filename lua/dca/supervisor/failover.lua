-- dca.supervisor.failover: where a child restarts after its host was lost (ARCHITECTURE.md "Failover"). Pure:
-- no I/O, specs in, hosts and specs out.
--
-- A child's hosts, in order (its first the host it was written with):
--   a leaf: its own standby hosts (`standby inst on h2b;`) after its host; else, when it runs on its group's
--           host, the group's standby hosts (`host { h2, h2b }`), which cover the leaves placed on it; else none;
--   a sub-group: its group spec's `hosts` (`host { h2, h2b }` in its definition).
-- After a `lost` fault the child restarts on the host after the one it was lost on; past the last there is
-- none (it restarts where it was, which fails while that host is down: the fault escalates).
--
--   failover.hosts(child, group_spec)  --> { host... } | nil   (child: a spec child of group_spec)
--   failover.next_host(list, current)  --> the host after `current` in `list`, or nil
--   failover.moved(group_spec, from, to) --> a copy of the group spec with every host `from` of its subtree
--                                          (the group's own, its leaves', its sub-groups') replaced by `to`,
--                                          but a leaf's with standby hosts of its own, by the first of them
local spec_mod = require "dca.supervisor.spec"

local M = {}

local ipairs = ipairs

function M.hosts(child, group_spec)
  if child.kind == "group" then return child.spec and child.spec.hosts end
  if child.standby and #child.standby > 0 then
    local list = { child.host }
    for _, h in ipairs(child.standby) do list[#list + 1] = h end
    return list
  end
  local gh = group_spec and group_spec.hosts
  if gh and #gh > 1 and child.host == gh[1] then return gh end
  return nil
end

function M.next_host(list, current)
  for i, h in ipairs(list or {}) do
    if h == current then return list[i + 1] end
  end
  return nil
end

function M.moved(group_spec, from, to)
  local s = spec_mod.copy(group_spec)
  local function visit(g)
    if g.host == from then g.host = to end
    for _, c in ipairs(g.children or {}) do
      -- a leaf with standby hosts of its own goes to the first of them, any other to `to`
      if c.host == from then c.host = c.kind == "leaf" and c.standby and c.standby[1] or to end
      if c.kind == "group" and c.spec then visit(c.spec) end
    end
  end
  visit(s)
  return s
end

return M
