-- dca.supervisor.taps (ARCHITECTURE.md "Taps"): the ports a selection names, the errors for unknown ones, and
-- `dca run --record-ports`: refused without an MCAP recording or for an unknown port before anything starts, and
-- a tapped port of a leaf restarted by its group's policy recorded on after every restart.
local T = require "dca.testing"
local taps = require "dca.supervisor.taps"
local suite = T.suite("taps")

local dca, src = T.exe, T.src

local function door_spec()
  return assert(require("dca.load").spec(src .. "/worlds/door/systems/door_open.dca", {}))
end

suite:case("all_selects_every_leaf_output_of_the_tree", function()
  local list = assert(taps.select(door_spec(), require("dca.core").types(), "all"))
  T.eq(#list, 22, "outputs of the door system")
  local by = {}
  for _, p in ipairs(list) do by[p.path] = p end
  local cmd = by["main.dooropensyst.motionctrl.xr4000.Cmd"]
  T.ok(cmd, "xr4000.Cmd is selected")
  T.eq(cmd.leaf, "main.dooropensyst.motionctrl.xr4000")
  T.eq(cmd.type, "vector")
  T.eq(cmd.size, 3)
end)

suite:case("unknown_ports_are_named_with_their_leafs_outputs", function()
  local spec, types = door_spec(), require("dca.core").types()
  local list = assert(taps.select(spec, types, "main.dooropensyst.hit.force.Wrench, main.dooropensyst.camera.Feature"))
  T.eq(#list, 2)
  local none, err = taps.select(spec, types, "main.dooropensyst.hit.force.Nope,main.nowhere.X")
  T.eq(none, nil)
  T.contains(err, "main.dooropensyst.hit.force has no output 'Nope' (outputs: Wrench)")
  T.contains(err, "no leaf main.nowhere in main")
end)

suite:case("record_ports_needs_an_mcap_recording_and_known_ports", function()
  local system = src .. "/worlds/door/systems/door_open.dca"
  local out, rc = T.sh(dca .. " run " .. system .. " --sim door --record-ports all")
  T.eq(rc, 2, "exit code")
  T.contains(out, "--record-ports goes with --record FILE.mcap")
  out, rc = T.sh(dca .. " run " .. system .. " --sim door --record /tmp/x.mcap --record-ports main.x.Y")
  T.eq(rc, 2, "exit code")
  T.contains(out, "--record-ports: no leaf main.x in main")
  T.ok(not out:find("daemon at", 1, true), "nothing started:\n" .. out)
end)

-- The first samples of port `topic` in the recording `file` (value 1: each new Counter process's first), removed.
local function first_samples(file, topic)
  local rec = assert(require("dca.core").mcap_read(file))
  os.remove(file)
  local id
  for k, c in pairs(rec.channels) do if c.topic == topic then id = k end end
  T.ok(id, "the port's channel " .. topic)
  local after = {}
  for _, m in ipairs(rec.messages) do
    if m.channel == id and m.data == '{"value":1}' then after[#after + 1] = m.t end
  end
  return after
end

-- A system of scripts/systems/ run in simulated time, recording main.loop.steady.Count to a scratch file; it
-- ends ABORTED by its restart intensity. --> the run's output, the recording's path
local function run_recording_steady(system)
  local file = T.tmpname(".mcap")
  local out, rc = T.sh("timeout 120 " .. dca .. " run " .. src .. "/scripts/systems/" .. system .. " --sim door"
    .. " --record " .. file .. " --record-ports main.loop.steady.Count")
  T.kept_logs(out)
  T.eq(rc, 1, "the run ends ABORTED (restart intensity)\n" .. out)
  return out, file
end

suite:case("a_restarted_leafs_port_is_recorded_on_its_new_process", function()
  local out, file = run_recording_steady("test_taps_restart.dca")
  T.contains(out, "main.loop.steady: restarted")
  -- the Counter counts 1, 2, 3, 4 every 20 ms, and again from 1 on each of its three new processes
  local after = first_samples(file, "/main/loop/steady/Count")
  -- each at its process's first tick: 20 ms after the start, then after each restart at 100, 200, 300 ms (its
  -- group re-taps it inside the restart, so at the restart's tick, before time moves on)
  T.eq(#after, 4, "a first sample of each of its four processes")
  for i, t in ipairs({ 20e6, 120e6, 220e6, 320e6 }) do T.eq(after[i], math.tointeger(t), "first sample " .. i) end
end)

suite:case("a_restarted_sub_groups_ports_are_recorded_on_its_new_processes", function()
  -- the parent remembers the taps of the whole subtree and makes them again inside the restart of the group
  local out, file = run_recording_steady("test_taps_group_restart.dca")
  T.contains(out, "main.loop: restarted")
  -- each new Loop supervisor takes the clock's counts so far as had: the losses of crashy before it are not
  -- waited for (it killed its own new crashy with SIGKILL after 1 s, at the restart's tick)
  T.eq(select(2, out:gsub("crashy: exited: killed by SIGSEGV", "")), 4, "every crash its own\n" .. out)
  T.ok(not out:find("SIGKILL", 1, true), out)
  local after = first_samples(file, "/main/loop/steady/Count")
  T.eq(#after, 4, "a first sample of each of its four processes\n" .. out)
  -- each restart of the group takes effect at its crash's tick (crashy crashes 100 ms after each start): time
  -- is held by the barrier until the new group runs, whose steady counts first one period later
  local crashes, restarts = {}, {}
  for t in out:gmatch("%[sim%s+([%d.]+)%] main%.loop%.crashy: exited: killed") do crashes[#crashes + 1] = t end
  for t in out:gmatch("%[sim%s+([%d.]+)%] main%.loop: restarted") do restarts[#restarts + 1] = t end
  T.eq(#restarts, 3, "three restarts\n" .. out)
  for i, t in ipairs({ "0.100", "0.200", "0.300" }) do
    T.eq(crashes[i], t, "crash " .. i .. "\n" .. out)
    T.eq(restarts[i], t, "restart " .. i .. " at its crash's tick\n" .. out)
  end
  for i, t in ipairs({ 20e6, 120e6, 220e6, 320e6 }) do T.eq(after[i], math.tointeger(t), "first sample " .. i) end
end)

suite:case("a_consoles_tap_request_links_one_port_through_the_tree_and_a_restart_makes_it_again", function()
  -- `dca monitor ADDR` plotting a port: the console asks the root `ports`, then `tap {path, to}` (its own tap
  -- point's name); the root links the leaf's output through the tree, remembered so a restart makes it again
  local fake = require "dca.supervisor.memory"
  local types = { Run = { inputs = {}, outputs = { { name = "Out", type = "scalar" } } } }
  local low = fake.group("low", "Low", "h2", "x", { fake.leaf("x", "Run", "h2") })
  local spec = fake.root("main", "h1", "low", { low })
  spec.supervision = { strategy = "one_for_one", intensity = 3, within = 10, on = { crash = true, aborted = true } }
  local c = fake.cluster{ behave = {}, types = types }
  c:root(spec)
  assert(c:configure())
  c:start()
  local function ask(msg)
    local r
    c.root_sup:handle(msg, function(x) r = x end)
    c:settle(c.t + 1)
    return r
  end
  local ports = ask({ type = "ports" })
  T.eq(ports.type, "ok")
  T.eq(ports.host, "h1", "the root's host (where the console's tap point registers)")
  T.eq(ports.sim, false, "not on simulated time (wall-clock stamps at the viewer)")
  T.eq(#ports.ports, 1)
  T.eq(ports.ports[1].path, "main.low.x.Out")
  T.eq(ports.ports[1].type, "scalar")
  local r = ask({ type = "tap", path = "main.low.x.Out", to = "taps:main@7" })
  T.eq(r.type, "ok", r.reason)
  T.eq(r.port.leaf, "main.low.x")
  local TAP = "tap:main.low.x.Out"
  local x = c:node("main.low.x")
  T.eq(x.conns[#x.conns].to, "taps:main@7")
  T.eq(x.active[TAP], true)
  T.contains(ask({ type = "tap", path = "main.low.x.Nope", to = "t" }).reason, "has no output 'Nope' (outputs: Out)")
  T.contains(ask({ type = "tap", path = "main.low.x.Out" }).reason, "tap {path")
  -- a second viewer of the same port (the run's own tap point): both links are made again after a restart
  c.root_sup:to_leaf("main.low.x", { type = "connect", set = TAP, out = "Out", to = "taps:main@1", ["in"] = TAP,
                                     stamped = true })
  c:settle(c.t + 1)
  c:kill("main.low.x", "SEGV")
  c:settle(c.t + 1)
  local again = c:node("main.low.x")
  T.ok(again ~= x, "main.low (x in it) restarted by main's policy")
  T.eq(again.active[TAP], true, "made again on the restarted process")
  local tos = {}
  for _, l in ipairs(again.conns) do if l.set == TAP then tos[#tos + 1] = l.to end end
  T.eq(tos, { "taps:main@7", "taps:main@1" }, "each destination's link made again")
  -- the console's tap point gone: its link fails on the next restart, is logged and forgotten; the other stays
  c.refuse_to = { ["taps:main@7"] = "no component taps:main@7" }
  c:kill("main.low.x", "SEGV")
  c:settle(c.t + 1)
  T.eq(c:node("main.low.x").active[TAP], true, "the other link's set activated")
  local remembered = c.root_sup.children.low.taps["main.low.x " .. TAP]
  T.eq(remembered.to, { "taps:main@1" }, "the failed destination forgotten")
  local logged = false
  for _, l in pairs(c.root_sup.logbuf) do logged = logged or l:find("no component taps:main@7", 1, true) ~= nil end
  T.ok(logged, "the failed tap is logged (the log ring)")
  -- the console's allow-list admits both requests
  local net = require "dca.supervisor.net"
  T.ok(net.CONSOLE.ports and net.CONSOLE.tap)
end)

return suite:run(...)
