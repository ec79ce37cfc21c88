-- The door world's descriptor (dca.worlds, docs/worlds.md): what the run machinery and the monitor know of it.
--   report: its part of a simulated run's summary (`dca run --sim door`): the angle the door opened to, and the
--     control periods the leaves of every MotionControl group achieved (intervals between their MainCalc calls,
--     from their nodes' `stats`, asked before the tree stops):
--       door opened to NN.N deg
--       MotionControl period PATH: nominal 1.000 ms; sim n N p50 .. ms p99 .. ms max .. ms;
--         wall n N p50 .. ms p99 .. ms p999 .. ms max .. ms        (one line)
-- Its options (door_width, jammed, ...) are the C++ plug-in's (worlds/door/plugin.cpp; `dca sim --worlds`).
local clients = require "dca.clients"
local node = require "dca.clients.node"
local spec_mod = require "dca.supervisor.spec"

local M = {}  -- the report hook

local ipairs, tostring, sformat, tonumber = ipairs, tostring, string.format, tonumber

--- The leaves whose control periods the summary reports: those of every group of type `group_type`
--- (default "MotionControl", the paper's motion controller) in `spec`, in declaration order.
function M.leaves(spec, group_type)
  group_type = group_type or "MotionControl"
  local list = {}
  spec_mod.walk(spec, function(n)
    if n.kind == "group" and n.type == group_type then
      for _, c in ipairs(n.spec.children) do
        if c.kind == "leaf" then list[#list + 1] = c.path end
      end
    end
  end)
  return list
end

--- The lines that open the summary, from the world's status.
function M.head(status)
  if not status.door_angle then return {} end
  return { sformat("door opened to %.1f deg", math.deg(tonumber(status.door_angle) or 0)) }
end

local function ms(us) return (tonumber(us) or 0) / 1000 end

--- The summary line of one leaf's period figures (an `intervals` entry of its node's `stats` reply).
function M.period_line(path, iv)
  local c, w = iv.clock or {}, iv.wall or {}
  return sformat("MotionControl period %s: nominal %.3f ms; sim n %d p50 %.3f ms p99 %.3f ms max %.3f ms; "
    .. "wall n %d p50 %.3f ms p99 %.3f ms p999 %.3f ms max %.3f ms", path, (tonumber(iv.period_s) or 0) * 1000,
    tonumber(c.n) or 0, ms(c.p50_us), ms(c.p99_us), ms(c.max_us), tonumber(w.n) or 0, ms(w.p50_us), ms(w.p99_us),
    ms(w.p999_us), ms(w.max_us))
end

-- The lines of one leaf from its node's stats reply.
local function stats_lines(path, r)
  local lines = {}
  for _, iv in ipairs(r.intervals or {}) do
    if iv.name == path or #r.intervals == 1 then lines[#lines + 1] = M.period_line(path, iv) end
  end
  if #lines == 0 then lines[1] = sformat("MotionControl period %s: it ran no periodic timer", path) end
  return lines
end

-- The period lines of one leaf, its node found through `daemon`: cb(lines).
local function one_leaf(path, daemon, key, cb)
  local function say(what) cb({ sformat("MotionControl period %s: %s", path, what) }) end
  if not daemon then say("no daemon to ask") return end
  clients.open(daemon, path, 2, clients.key_opts(key), node.Client, function(n, err, missing)
    if not n then say(missing and sformat("not found (%s)", tostring(err)) or tostring(err)) return end
    n:stats(clients.result(function(r, serr)
      n:close()
      if not r then say(sformat("no stats (%s)", tostring(serr))) return end
      cb(stats_lines(path, r))
    end))
  end)
end

--- Asks each leaf for its node's stats (one at a time, each bounded) and calls back with the lines: one per
--- periodic timer of the leaf, or why there is none.
function M.tail(leaves, daemon, key, cb)
  local lines, i = {}, 0
  local function next_leaf()
    i = i + 1
    if not leaves[i] then cb(lines) return end
    one_leaf(leaves[i], daemon, key, function(ls)
      for _, l in ipairs(ls) do lines[#lines + 1] = l end
      next_leaf()
    end)
  end
  next_leaf()
end

return {
  report = M,
  -- the door's angles and the base's pose from the world's status, under the names and units of the world's own
  -- signals (door.angle, ...: their live topics and recorded channels), where no tap feeds them (an attached
  -- monitor; `dca run --monitor` taps them from the start)
  topics = {
    { topic = "/world/door/angle", value = "door_angle", units = "rad" },
    { topic = "/world/door/handle_angle", value = "handle_angle", units = "rad" },
    { topic = "/world/base/pose", array = "base_pose", units = "m, m, rad" },
  },
  -- what `dca plot` draws of a recording by default: the door's angles, the wrist force, the base's position; as
  -- `dca run` records them (one channel a signal, as live) and as `dca sim --record` does (its signal groups)
  plot = { "/world/door/angle[0]", "/world/door/handle_angle[0]", "/world/wrist/wrench[0]", "/world/wrist/wrench[1]",
           "/world/wrist/wrench[2]", "/world/base/pose[0]", "/world/base/pose[1]",
           "/world/door.*", "/world/wrench.f*", "/world/base.x", "/world/base.y" },
}
