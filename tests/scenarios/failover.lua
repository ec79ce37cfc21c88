-- Failover (docs/supervision.md, "Failover"): hosts are lost mid-run and their children restart on their
-- standby hosts, with every connection made again, and the task carries on (scripts/systems/test_failover.dca).
--  1. host manip lost: ctrl.gain (standby base) restarts on base; the link from vision.track (another group's
--     controller, pointing directly at it) is made again by the root, and its link to ctrl.sink, which runs on
--     base, is now a Unix socket instead of TCP.
--  2. host vision lost: the supervisor of the group vision is lost with both its leaves; the root restarts the
--     whole group on its standby host vision2, and samples flow from its new cam through to ctrl.sink again;
--     track, with a standby host of its own, comes up on vision3: cam -> track was a Unix socket (in process
--     under a shared placement), it is TCP now.
-- With real processes: one daemon per host name on loopback (base, manip, manip's standby is base, vision,
-- vision2), a host lost as tests/scenarios/host_lost.lua loses it (its daemon and its processes killed).
local S = require "dca.scenario"
local src = os.getenv("DCA_SOURCE_DIR") or "."
local sys = S.system(src .. "/scripts/systems/test_failover.dca")
local real = sys.backend == "real"
-- two leaves on one host: a Unix socket between their nodes, or in process in one shared node (`dca scenario
-- --placement group|host`, ARCHITECTURE.md "Placement")
local together = (S.placement or "process") == "process" and "unix" or "inprocess"

local GAIN, SINK, CAM, TRACK = "main.ctrl.gain", "main.ctrl.sink", "main.vision.cam", "main.vision.track"

-- Where the process of `path` runs now: { host =, pid = } (real: its registration, looked up from base, whose
-- daemon reaches its peers; memory: the in-memory cluster's live process).
local function where(path)
  if not real then
    for _, p in ipairs(sys.c.procs) do if p.path == path and p.alive then return { host = p.host, pid = p.pid } end end
    return {}
  end
  local ep = sys:_ask(function(k) require("dca.clients").lookup(sys:_daemon("base"), path, 0, k) end, 25, path)
  return ep or {}
end

-- The ports of `path` (real: its node's `ports`).
local function ports(path)
  return sys:_ask(function(k) sys.sup:to_leaf(path, { type = "ports" }, 20, k) end, 25, "the ports of " .. path)
end

-- The samples input `port` of `path` has taken (real), or nil.
local function samples(path, port)
  if not real then return nil end
  for _, i in ipairs(ports(path).inputs or {}) do if i.name == port then return i.samples end end
end

-- Waits until samples flow into `path`.`port` again: more than it had taken (real), or a value at all (a
-- process started anew reads nothing until its first sample comes); in memory the input is first marked stale,
-- which only a sample arriving from now on replaces (the writers write the same value every period).
local function flows(path, port)
  local n0 = samples(path, port)
  if n0 then
    sys:wait(path .. "." .. port .. " taking samples", function() return samples(path, port) > n0 end, 10)
  end
  if not real then sys.c:node(path).ports[port] = "stale" end
  return sys:wait_read(path, port, function(v) return tonumber(v) ~= nil end, 10)
end

-- The transport of the link from `from` to `to` (real only: the source node's `ports`).
local function transport(from, to)
  for _, l in ipairs(ports(from).links or {}) do
    if l.to == to and not l.broken then return l.transport end
  end
end

S.step("the system runs on base, manip and vision: samples flow from vision.cam to ctrl.sink", function()
  sys:up()
  sys:run()
  flows(SINK, "In")
  S.eq(where(GAIN).host, "manip")
  if real then S.eq(transport(GAIN, SINK), "tcp", "manip -> base") end
end)

S.step("host manip lost: ctrl.gain restarts on its standby host base, its links made again", function()
  local before = where(GAIN).pid
  sys:lose_host("manip")
  sys:wait("ctrl.gain on base", function() return where(GAIN).host == "base" and sys:state(GAIN) == "running" end, 20)
  S.ok(where(GAIN).pid ~= before, "a new process")
  local seen
  for _, l in ipairs(sys:transitions()) do seen = seen or l:find(GAIN .. ": moves from host manip to host base", 1, true) end
  S.ok(seen, "a transition line says it moved")
  -- its input again from vision.track (the root's connection), its output again to ctrl.sink
  flows(GAIN, "In")
  flows(SINK, "In")
  if real then S.eq(transport(GAIN, SINK), together, "both on base now") end
  S.eq(sys.outcome, nil, "the task runs on")
end)

S.step("host vision lost: the group vision restarts on vision2 with its subtree, samples flow again", function()
  local before = where(CAM).pid
  if real then S.eq(transport(CAM, TRACK), together, "cam and track together on vision") end
  sys:lose_host("vision")
  sys:wait("vision's leaves on vision2 and vision3", function()
    return where(CAM).host == "vision2" and where(TRACK).host == "vision3" and sys:state(CAM) == "running"
      and sys:state(TRACK) == "running"
  end, 30)
  S.ok(where(CAM).pid ~= before, "a new process")
  flows(TRACK, "In")
  flows(SINK, "In")
  if real then S.eq(transport(CAM, TRACK), "tcp", "cam on vision2, track on vision3") end
  S.eq(sys.outcome, nil, "the task runs on")
  S.eq(sys:state(GAIN), "running", "ctrl.gain never stopped")
end)
return S.finish()
