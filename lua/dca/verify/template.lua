-- dca.verify.template: what the verifier proves of a group's templates (a fleet: docs/verify.md, "A fleet"), for any
-- number of instances.
--
--   template.explore(node, explore_group, faults) --> { { name, path, type, kind, hosts, instance = r | nil,
--                                                   --   policy = node.supervision, escalates = bool } ... }
--   template.fault_reasons(name, r)             --> the fault reasons a parent sees of group r's templates
--   template.lines(r)                           --> the report's lines of group r's templates
--
-- Why one instance suffices. dca.lang.check makes an instance independent of its group's expression: a template
-- is never named in the expression nor in a connection (nor in a verify { } property), so no event of an instance
-- is an event of the expression, no connection set writes to or reads from it, and the expression's exploration
-- is the same whatever number of instances run beside it. Instances of one template differ only in their host
-- (the type's first argument), which no behaviour the verifier models depends on: one exploration of the type (a
-- group, memoized by process definition as every group is) holds for each of them. An instance reaches its
-- group's outcome only through the group's supervision policy: a fault it covers is a restart, past the intensity
-- an escalation (the group ends ABORTED by a fault). With faults on, that is one more fault reason of the group
-- (any group can already end by a fault at any time, seen from its parent, so the parent's exploration is
-- unchanged); without a policy, or with --no-faults, an instance's end ends only that instance.
-- Not proven here: the device writers of instances (dca.verify.writers sees the tree's declared instances only).
local M = {}

local ipairs, sformat, concat = ipairs, string.format, table.concat

-- Whether the group's policy restarts crashes or lost hosts: its instances' faults can then escalate it.
local function escalates(pol)
  return pol ~= nil and pol.on ~= nil and (pol.on.crash or pol.on.lost) == true
end

function M.explore(node, explore_group, faults)
  local out = {}
  for _, t in ipairs(node.templates or {}) do
    local first = t.instances[1]
    local item = { name = t.name, path = t.path, type = t.type, kind = t.kind, hosts = t.hosts, policy = node.supervision,
                   escalates = faults and escalates(node.supervision) or false }
    if first and first.kind == "group" then item.instance = explore_group(first) end
    out[#out + 1] = item
  end
  return out
end

function M.fault_reasons(name, r)
  local out = {}
  for _, t in ipairs(r.templates or {}) do
    if t.escalates then
      out[#out + 1] = { text = sformat("%s escalated: an instance of %s crashed or lost its host past the restart "
        .. "intensity", name, t.name), fault = true }
    end
  end
  return out
end

function M.lines(r)
  local out = {}
  for _, t in ipairs(r.templates or {}) do
    local what = t.instance and sformat("verified once as %s (process %s)", t.instance.path, t.instance.type)
      or sformat("a leaf of type %s", t.type)
    out[#out + 1] = sformat("  template  %s: any number of instances on { %s }, each %s, independent of the "
      .. "expression", t.name, concat(t.hosts, ", "), what)
    local pol = t.policy
    if t.escalates then
      out[#out + 1] = sformat("            their faults are restarts (%s, %d in %g s); past that the group ends "
        .. "ABORTED by a fault (escalated)", pol.strategy, pol.intensity, pol.within)
    else
      out[#out + 1] = "            an instance's end or fault ends that instance only: never this group's outcome"
    end
  end
  return out
end

return M
