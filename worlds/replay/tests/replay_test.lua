-- The replay world (docs/recording.md, "Replay"): the door run recorded with every port, then run again against
-- its recording (`dca run --replay REC.mcap`: the world's outputs from the file, no Simbody, every controller
-- live): every controller output equals the recording tick for tick (`dca trace diff REC.mcap NEW.mcap` says
-- identical); a changed gain is named at its first differing tick and port. With --replay-ports the sensors
-- and a controller's outputs are written again from the file in place of their live writers: still identical,
-- and a gain changed in a replayed controller changes its own (recorded) output but not what its readers got.
-- And the refusals before a start.
local T = require "dca.testing"
local suite = T.suite("replay")

local dca, src = T.exe, T.src
local system = src .. "/worlds/door/systems/door_open.dca"

local function run(args)
  return T.sh("timeout 600 " .. dca .. " run " .. system .. " --quiet " .. args)
end

local function diff(a, b)
  return T.sh(dca .. " trace diff " .. a .. " " .. b)
end

-- The door run recorded with every port (each case runs in a process of its own, and removes it).
local function recorded()
  local rec = T.tmpname(".mcap")
  local out, rc = run("--sim door --record " .. rec .. " --record-ports all")
  T.eq(rc, 0, "the recorded run:\n" .. out)
  return rec
end

suite:case("a_replay_gives_every_output_again_and_a_changed_gain_is_named", function()
  local rec, again, changed = recorded(), T.tmpname(".mcap"), T.tmpname(".mcap")
  local out, rc = run("--replay " .. rec .. " --record " .. again .. " --record-ports all")
  T.eq(rc, 0, "the replay:\n" .. out)
  out, rc = diff(rec, again)
  T.eq(rc, 0, "dca trace diff:\n" .. out)
  T.contains(out, "identical: ")
  local channels = tonumber(out:match("on (%d+) channels compared"))
  T.ok(channels and channels >= 23, "every port and the world's outputs compared: " .. out)
  out, rc = run("--replay " .. rec .. " --set motion.damping=0.05 --record " .. changed .. " --record-ports all")
  T.ok(rc == 0 or rc == 1, "the replay with another damping ends:\n" .. out)
  out, rc = diff(rec, changed)
  T.eq(rc, 1, "dca trace diff:\n" .. out)
  T.contains(out, "first difference at tick ")
  T.contains(out, "/main/dooropensyst/motionctrl/")
  for _, f in ipairs({ rec, again, changed }) do os.remove(f) end
end)

-- The messages of `topic` in a recording: "t data" each.
local function series(file, topic)
  local rec = assert(require("dca.core").mcap_read(file))
  local out = {}
  for _, m in ipairs(rec.messages) do
    if rec.channels[m.channel].topic == topic then out[#out + 1] = m.t .. " " .. m.data end
  end
  return out
end

-- Every sensor of the door system (the leaves that read the world's signals and write what they measure).
local SENSORS = "main.dooropensyst.camera,main.dooropensyst.pressft,main.dooropensyst.pressjoints,"
  .. "main.dooropensyst.dooropen.force,main.dooropensyst.dooropen.xr4000,main.dooropensyst.dooropen.puma,"
  .. "main.dooropensyst.hit.force,main.dooropensyst.distdetect.laser,main.dooropensyst.motionctrl.puma.Joints"

-- The redundancy resolution replayed with another damping (the recording `rec`, the new one into `changed`).
local function changed_gain_is_its_own(rec, changed)
  local out, rc = run("--replay " .. rec .. " --replay-ports " .. SENSORS .. ",main.dooropensyst.motionctrl.redundancy"
    .. " --set motion.damping=0.05 --record " .. changed .. " --record-ports all")
  T.eq(rc, 0, "the replay with another damping:\n" .. out)
  out, rc = diff(rec, changed)
  T.eq(rc, 1, "dca trace diff:\n" .. out)
  T.contains(out, "first difference at tick 4.080000000 s (4080000000 ns), message 408 of "
    .. "/main/dooropensyst/motionctrl/redundancy/ArmVel:")
  for _, port in ipairs({ "puma/Cmd", "xr4000/Cmd" }) do
    local a, b = series(rec, "/main/dooropensyst/motionctrl/" .. port), series(changed, "/main/dooropensyst/motionctrl/" .. port)
    -- (the writes of the end's tick race the stop of the leaves: one more or less, as `dca trace diff` knows)
    local n = math.min(#a, #b)
    T.ok(n > 1000 and math.abs(#a - #b) <= 1, port .. ": as many commands as recorded: " .. #a .. ", " .. #b)
    for i = 1, n do if a[i] ~= b[i] then T.eq(b[i], a[i], port .. " message " .. i) end end
  end
end

suite:case("replayed_ports_stand_in_for_their_live_writers", function()
  local rec, again, changed = recorded(), T.tmpname(".mcap"), T.tmpname(".mcap")
  -- the sensors and one controller's output from the file, the rest live: every output as recorded
  local out, rc = run("--replay " .. rec .. " --replay-ports world," .. SENSORS
    .. ",main.dooropensyst.dooropen.compliant.Vel --record " .. again .. " --record-ports all")
  T.eq(rc, 0, "the replay:\n" .. out)
  out, rc = diff(rec, again)
  T.eq(rc, 0, "dca trace diff:\n" .. out)
  T.contains(out, "identical: ")
  -- the redundancy resolution replayed with another damping: its own live output differs at its first
  -- tick, named; its readers got the recorded samples, so their commands are the recorded ones (a third door
  -- run, through the same C++ as the one above: not under the sanitizers, where each is several times slower)
  if not T.sanitized then changed_gain_is_its_own(rec, changed) end
  out, rc = run("--replay " .. rec .. " --replay-ports main.nowhere,main.dooropensyst.camera.Nope")
  T.eq(rc, 2, "exit code:\n" .. out)
  T.contains(out, "--replay-ports: 'main.nowhere' names no output, leaf or group of main")
  T.contains(out, "'main.dooropensyst.camera.Nope' names no output")
  T.ok(not out:find("daemon at", 1, true), "nothing started:\n" .. out)
  for _, f in ipairs({ rec, again, changed }) do os.remove(f) end
end)

-- A URDF world (the UR10, on Simbody and on the mock) replayed: identical from tick 0 on, its joints' start
-- (initial_value), -0s and link frames (foxglove.FrameTransforms, named as recorded) included.
suite:case("a_urdf_world_replay_is_identical_from_its_first_tick", function()
  local setpoint = src .. "/worlds/ur10/ur10_setpoint.dca"
  for _, sim in ipairs({ src .. "/worlds/ur10/ur10.urdf", "mock:" .. src .. "/worlds/ur10/ur10.urdf" }) do
    local rec, again = T.tmpname(".mcap"), T.tmpname(".mcap")
    local out, rc = T.sh("timeout 600 " .. dca .. " run " .. setpoint .. " --quiet --sim " .. sim .. " --record " .. rec
      .. " --record-ports all")
    T.eq(rc, 0, sim .. ": the recorded run:\n" .. out)
    out, rc = T.sh("timeout 600 " .. dca .. " run " .. setpoint .. " --quiet --replay " .. rec .. " --record " .. again
      .. " --record-ports all")
    T.eq(rc, 0, sim .. ": the replay:\n" .. out)
    out, rc = diff(rec, again)
    T.eq(rc, 0, sim .. ": dca trace diff:\n" .. out)
    T.contains(out, "identical: ")
    local first = series(again, "/world/links/frames")[1] or ""
    T.contains(first, '"child_frame_id":"tool0"')
    for _, f in ipairs({ rec, again }) do os.remove(f) end
  end
end)

suite:case("a_replay_is_refused_before_a_start_when_it_cannot_be", function()
  local out, rc = run("--replay x.mcap --sim door")
  T.eq(rc, 2, "exit code")
  T.contains(out, "--replay and --sim exclude each other")
  local plain = T.tmpname(".mcap")
  local f = assert(io.open(plain, "wb"))
  f:write("not an mcap file")
  f:close()
  out, rc = run("--replay " .. plain)
  T.eq(rc, 2, "exit code:\n" .. out)
  T.contains(out, plain .. ": ")
  T.ok(not out:find("daemon at", 1, true), "nothing started:\n" .. out)
  os.remove(plain)
  out, rc = run("--sim door --replay-ports main.dooropensyst.camera")
  T.eq(rc, 2, "exit code:\n" .. out)
  T.contains(out, "--replay-ports goes with --replay REC.mcap")
end)
return suite:run(...)
