-- `dca run --blackbox BEFORE,AFTER` (docs/recording.md, "Black box"): the door run with its handle jammed
-- aborts at a tick a full recording shows; the black box of the same run writes one file that names that
-- trigger and holds exactly the full recording's messages of [t - before, t + after], the run's lines included.
-- The root aborts at that same tick, and what the world writes after the run's end (time runs on while the tree
-- stops) depends on the wall clock: the exact comparison stops at the end's tick, the C++ test
-- (tests/sim/blackbox_test.cpp) checks the whole window.
local T = require "dca.testing"
local suite = T.suite("blackbox")

local dca, src = T.exe, T.src
local core = require "dca.core"
local system = src .. "/worlds/door/systems/door_open.dca"

local function run(args)
  return T.sh("timeout 600 " .. dca .. " run " .. system .. " --quiet --sim door --world-opt jammed " .. args)
end

-- The messages of `rec` by topic, as "T DATA" texts, those in [from, to] ns (the lines' own channel aside).
local function window(rec, from, to, skip)
  local out = {}
  for _, m in ipairs(rec.messages) do
    local topic = rec.channels[m.channel].topic
    if m.t >= from and m.t <= to and not skip[topic] then
      out[topic] = out[topic] or {}
      table.insert(out[topic], m.t .. " " .. m.data)
    end
  end
  return out
end

suite:case("a_fault_writes_the_window_of_the_full_recording_around_it", function()
  local full, box = T.tmpname(".mcap"), T.tmpname(".mcap")
  local out, rc = run("--record " .. full .. " --record-ports all")
  T.eq(rc, 1, "the jammed door aborts:\n" .. out)
  out, rc = run("--record " .. box .. " --record-ports all --blackbox 1,0.5")
  T.eq(rc, 1, "the jammed door aborts:\n" .. out)
  T.contains(out, "black box, 1 written")
  local file = box:gsub("%.mcap$", "-1.mcap")
  local f = assert(core.mcap_read(full))
  local b = assert(core.mcap_read(file))
  -- the fault's tick: the full recording's first aborted line
  local t_fault, t_end
  for _, m in ipairs(f.messages) do
    if f.channels[m.channel].topic == "/dca/events" and m.data:find('"state":"aborted"', 1, true) then
      t_fault = t_fault or m.t
    end
    if f.channels[m.channel].topic == "/dca/events" and m.data:find('"state":"ABORTED"', 1, true) then
      t_end = t_end or m.t
    end
  end
  T.ok(t_fault, "an aborted line in the full recording")
  local trigger
  for _, m in ipairs(b.messages) do
    if b.channels[m.channel].topic == "/dca/blackbox" then trigger = m end
  end
  T.ok(trigger, "the trigger on /dca/blackbox")
  T.eq(trigger.t, t_fault, "the trigger's tick")
  T.contains(trigger.data, "aborted")
  local from, to = t_fault - 1000000000, math.min(t_fault + 500000000, t_end - 1)
  local skip = { ["/dca/blackbox"] = true, ["/dca/events"] = true, ["/dca/log"] = true }
  T.eq(window(b, from, to, skip), window(f, from, to, skip), "the full recording's window")
  -- the run's lines: those before the fault's tick as the full recording's, and the fault's own
  local lines, want = window(b, from, t_fault - 1, {})["/dca/events"], window(f, from, t_fault - 1, {})["/dca/events"]
  T.eq(lines, want, "the run's lines before the fault")
  local at = window(b, t_fault, t_fault, {})["/dca/events"]
  T.ok(at and table.concat(at, "\n"):find("presshandle: aborted", 1, true), "the fault's line")
  local last = 0
  for _, m in ipairs(b.messages) do last = math.max(last, m.t) end
  T.ok(last > t_fault and last <= t_fault + 500000000, "messages after the trigger, up to t + after")
  T.ok(b.messages[1] and f.messages[1], "both hold messages")
  for _, x in ipairs({ full, box, file }) do os.remove(x) end
end)

suite:case("a_black_box_needs_an_mcap_recording", function()
  local out, rc = T.sh(dca .. " run " .. system .. " --sim door --blackbox 1,1")
  T.eq(rc, 2, "exit code")
  T.contains(out, "--blackbox goes with --record FILE.mcap")
end)
return suite:run(...)
