-- dca.supervisor.policy: the pure part of a supervision policy (a group's `supervision { }` section, resolved
-- by dca.lang.model.policy into spec.supervision): which fault a child's end is, which children a strategy
-- restarts, the restart intensity's sliding window, and the texts. No I/O, no clock (times are given).
--
--   policy.kind(how, lost)                --> "crash" | "lost" | "aborted"
--     how: "exit" (the process ended: the Executer's signal or exit code, or, with `lost` true, its host, channel
--          or supervisor lost),
--          "aborted" (a leaf's ABORTED, or a sub-group's ABORTED outcome), "escalated" (a sub-group gave up:
--          its restart intensity was exceeded).
--   policy.plan(strategy, order, faulted)  --> names to restart, in start order (order: the instantiation order)
--   policy.window(times, now, within)      --> times pruned to (now - within, now] (in place, returned)
--   policy.budget(pol)                     --> "3 in 10 s"
--   policy.exceeded(pol, last)             --> "restart intensity 3 in 10 s exceeded; last: <last>"
local M = {}

local ipairs, sformat = ipairs, string.format

--- Which fault the end of a child is. A process that ended because its host or its supervisor's channel was
--- lost is `lost` (the runtime says so: `lost` is true, dca.supervisor.net and .memory; the reason's text is only
--- shown); any other end of a process (a signal, an exit code) is a `crash`; a sub-group that gave up
--- (escalated) is a `crash` of that child, as a supervisor that dies; an ABORTED end is `aborted`.
function M.kind(how, lost)
  if how == "aborted" then return "aborted" end
  if how == "exit" and lost == true then return "lost" end
  return "crash"
end

--- The children a strategy restarts after a fault of `faulted` (a set of names), in start (instantiation) order:
--- one_for_one the faulted ones, one_for_all every child, rest_for_one the first faulted and every one after it.
function M.plan(strategy, order, faulted)
  local out, from = {}, nil
  for i, name in ipairs(order) do
    if faulted[name] and not from then from = i end
  end
  for i, name in ipairs(order) do
    if strategy == "one_for_all" or (strategy == "rest_for_one" and from and i >= from) or faulted[name] then
      out[#out + 1] = name
    end
  end
  return out
end

--- Keeps the restart times within the window (now - within, now]: the sliding window of the intensity.
function M.window(times, now, within)
  local j = 0
  for _, t in ipairs(times) do
    if t > now - within then j = j + 1 times[j] = t end
  end
  for k = #times, j + 1, -1 do times[k] = nil end
  return times
end

--- "3 in 10 s": the budget of a policy.
function M.budget(pol)
  return sformat("%d in %g s", pol.intensity, pol.within)
end

--- The reason of a group that gave up: the budget, then the fault that exceeded it (which names the first
--- cause: a sub-group's reason holds its own last fault, down to the leaf that crashed first).
function M.exceeded(pol, last)
  return sformat("restart intensity %s exceeded; last: %s", M.budget(pol), last)
end

return M
