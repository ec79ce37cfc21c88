-- The replay world (docs/recording.md, "Replay"): the door run recorded with every port, then run again against
-- its recording (`dca run --replay REC.mcap`: the world's outputs from the file, no Simbody, every controller
-- live): every controller output equals the recording tick for tick (`dca trace diff REC.mcap NEW.mcap` says
-- identical); a changed gain is named at its first differing tick and port. And the refusals before a start.
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

suite:case("a_replay_gives_every_output_again_and_a_changed_gain_is_named", function()
  local rec, again, changed = T.tmpname(".mcap"), T.tmpname(".mcap"), T.tmpname(".mcap")
  local out, rc = run("--sim door --record " .. rec .. " --record-ports all")
  T.eq(rc, 0, "the recorded run:\n" .. out)
  out, rc = run("--replay " .. rec .. " --record " .. again .. " --record-ports all")
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
end)
return suite:run(...)
