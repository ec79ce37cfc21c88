-- dca.supervisor.net without daemons: a Proc over a fake daemon and channel, the runtime's lock-step barrier and
-- the end of a node that lost its channel. Bounded waits: a node whose exit never comes (its daemon gone) does
-- not hold the barrier for ever, and a node that closed its channel but lives on is killed before its restart.
local T = require "dca.testing"
local core = require "dca.core"
local net = require "dca.supervisor.net"
local suite = T.suite("net")

local loop = core.loop()

-- A runtime with fast graces, a fake supervisor recording child_exit, and one leaf Proc `main.a` (child 7 of
-- host h1's fake daemon, which records kills and never reports an exit).
local function setup()
  local logs, exits, kills = {}, {}, {}
  local rt = net.new({ hosts = {}, log = function(l) logs[#logs + 1] = l end,
                       lost_grace = 0.01, stop_grace = 0.02, exit_grace = 0.01 })
  rt.sup = { child_exit = function(_, name, reason, lost) exits[#exits + 1] = { name, reason, lost } end,
             children_exit = function() error("one leaf") end,
             child_message = function() end }
  local daemon = { kill = function(_, child, sig) kills[#kills + 1] = { child, sig } end }
  local ch = { close = function(c) c.closed = true end }
  local p = setmetatable({ rt = rt, daemon = daemon, name = "a", host = "h1", kind = "leaf", child = 7, pid = 4242,
                           path = "main.a", ch = ch }, net.Proc)
  rt.by_child["h1:7"] = p
  rt.my_leaves["main.a"] = true
  return { rt = rt, p = p, logs = logs, exits = exits, kills = kills }
end

suite:case("a_dropped_node_whose_exit_never_comes_ends_the_barrier_after_its_kill_and_a_grace", function()
  local s = setup()
  s.rt.ls.joined = true
  local replies = {}
  local master = { reply = function(_, id, payload) replies[#replies + 1] = { id, payload } end }
  -- the clock master dropped main.a at tick 1 s; its daemon is gone: the SIGKILL brings no exit
  s.rt._quiesce(master, 5, { t = 1e9, lost = { ["main.a"] = 1 } })
  T.ok(loop:run_until(function() return #replies == 1 end, 10), "the barrier ends")
  T.eq(s.kills, { { 7, "KILL" } }, "killed once")
  T.eq(replies[1][1], 5)
  T.eq(#s.exits, 1, "its end told once")
  T.eq(s.exits[1][1], "a")
  T.eq(s.exits[1][3], true, "as lost")
  T.contains(s.exits[1][2], "node lost on host h1: dropped by the clock master, no exit within 0.02s of SIGKILL")
  T.eq(#s.logs, 1)
  T.contains(s.logs[1], "main.a: node lost on host h1")
  T.contains(s.logs[1], "taken as arrived")
end)

suite:case("a_node_that_lost_its_channel_but_lives_on_is_killed_before_its_end_is_told", function()
  local s = setup()
  s.p:channel_closed("connection reset")
  T.ok(loop:run_until(function() return #s.kills > 0 end, 10), "killed")
  T.eq(s.kills[1], { 7, "KILL" })
  T.eq(s.exits, {}, "not told (so not restarted) while the old process may live")
  -- its exit (the SIGKILL's) comes from the daemon: now it is told, as lost, once
  s.p:exited_with(s.rt, "killed by SIGKILL on host h1", { child = 7 })
  s.p:gone()
  T.eq(s.exits, { { "a", "node lost on host h1: connection reset", true } })
  loop:run_until(function() return false end, 0.1)
  T.eq(#s.exits, 1, "once")
  T.contains(s.logs[1], "main.a (pid 4242 on host h1): node lost on host h1: connection reset; killed before its restart")
end)

suite:case("a_node_that_lost_its_channel_and_outlives_its_kill_is_told_lost_after_the_bounded_wait", function()
  local s = setup()
  s.p:channel_closed("connection reset")
  T.ok(loop:run_until(function() return #s.exits > 0 end, 10), "told in the end")
  T.eq(s.exits, { { "a", "node lost on host h1: connection reset", true } })
  T.eq(#s.kills, 2, "SIGKILL, and again after the grace")
  T.contains(s.logs[2], "did not exit within 0.02s of SIGKILL")
end)

-- A shared node of one group's leaves (--placement group) starts with the group's rt { } (the same for all of
-- them); one of a whole host's (--placement host) with none: leaves of several groups share it.
suite:case("a_shared_node_of_a_group_takes_its_rt_setting_and_one_of_a_host_none", function()
  local spawned = {}
  local dc = { spawn = function(_, argv) spawned[#spawned + 1] = table.concat(argv, " ", 3) end }
  local function open(placement, child)
    local rt = net.new({ hosts = { h1 = "127.0.0.1:1" }, placement = placement, log = function() end })
    rt.sup = { path = "main.g" }
    rt._start(child, dc, function() end)  -- (its methods are bound: called with a dot)
  end
  local leaf = { kind = "leaf", name = "a", path = "main.g.a", type = "Timer", host = "h1",
                 rt = { priority = 80, cpu = 1 } }
  open("group", leaf)
  open("host", leaf)
  T.eq(spawned, { "--shared leaves:main.g@h1 --daemon 127.0.0.1:1 --rt-priority 80 --rt-cpu 1",
                  "--shared leaves:main@h1 --daemon 127.0.0.1:1" })
end)

-- Fencing (docs/supervision.md): the heartbeat follows the group's fence; a standby waits fence + margin after
-- the last renewal sent to the lost host, only the margin after a close the daemon made, nothing without one.
suite:case("the_standby_waits_for_the_lost_hosts_leases_to_lapse", function()
  local s = setup()
  s.rt.sup.spec = { fence = { fence = 0.2, margin = 0.1 } }
  T.eq({ s.rt.heartbeat() }, { 0.05, 0.2 })
  s.rt.sup.spec = {}
  T.eq({ s.rt.heartbeat() }, { 1, 5 }, "the defaults: fence 5 s")
  s.rt.sup.spec = { fence = { fence = 0.2, margin = 0.1 } }
  local got = {}
  s.rt.fenced("h1", function(w) got[#got + 1] = { "h1", w } end)
  T.eq(got, { { "h1" } }, "nothing sent to h1: at once")
  s.rt._renewing("h2")
  s.rt.fenced("h2", function(w) got[#got + 1] = { "h2", w } end)
  s.rt._renewing("h3")
  s.rt.peer_closed.h3 = core.now()
  s.rt.fenced("h3", function(w) got[#got + 1] = { "h3", w } end)
  T.ok(loop:run_until(function() return #got == 3 end, 10), "both waits end")
  T.eq({ got[2][1], got[3][1] }, { "h3", "h2" }, "the closed one waits less")
  T.ok(got[2][2] > 0.05 and got[2][2] <= 0.1, "the margin after the close: " .. tostring(got[2][2]))
  T.ok(got[3][2] > 0.25 and got[3][2] <= 0.3, "fence + margin after the renewal: " .. tostring(got[3][2]))
end)

return suite:run(...)
