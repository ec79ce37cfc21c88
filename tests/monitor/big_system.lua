-- The 1,000-leaf / 100-group system of tests/bench/supervisor_bench.lua (generated shape: groups of 10 leaves
-- on hosts h1..h3, every group and the root running their operands concurrently), run by the real supervisor
-- engine on the in-memory cluster (dca.supervisor.memory), paced to the wall clock, watched by the web monitor
-- (dca.monitor.server, the same requests as `dca run --monitor`), with a sample topic at 1 kHz. For
-- tests/monitor/bench.mjs big: it prints the monitor's address, then "phase idle" (nothing happens for 5 s) and
-- "phase busy" (a run: 1,100 processes start at once, each leaf ends DONE after 1..8 s) ROUNDS times.
--   dca lua big_system.lua [ROUNDS]
local core = require "dca.core"
local fake = require "dca.supervisor.memory"
local srt = require "dca.supervisor.net"
local server = require "dca.monitor.server"

local rounds = tonumber((...)) or 2
local loop = core.loop()

-- The generated tree (tests/support/generated_tree.lua), without connection sets.
local generated = dofile(require("dca.testing").here() .. "/../support/generated_tree.lua")

-- One run of the system; its lines go to the monitor at the cluster's virtual time, paced to the wall clock.
local function one_run(mon, state, done)
  local rng = 0
  local c = fake.cluster{ behave = { Worker = function(node)
    rng = (rng * 1103515245 + 12345) % 2147483648
    node:after(1 + (rng % 7000) / 1000, function() node:done(1) end)
  end } }
  state.sup = c:root(generated(100, 10))
  state.cluster = c
  assert(c:configure())
  c:start()
  local t0, fed = core.now(), 0
  local timer
  timer = core.every(0.01, function()
    c:settle(core.now() - t0)
    for i = fed + 1, #c.lines do mon:line(c.lines[i], c.t) end
    fed = #c.lines
    if c.outcome then timer:cancel() done() end
  end)
end

local state = {}
local function request(msg, cb)
  if not state.sup then cb({ type = "error", reason = "not started" }) return end
  local ch = { reply = function(_, _, p) p.type = p.type or "ok" cb(p) return true end,
               reply_error = function(_, _, reason) cb({ type = "error", reason = reason }) return true end }
  srt.console(ch, 1, msg, state.sup, {})
  if state.cluster then state.cluster:settle(state.cluster.t) end  -- the children's answers
end

local mon = assert(server.start{ name = "main (1,000 leaves, in memory)", root = "main", mode = "live", request = request })
local topic = mon.srv:topic("/bench/signal", { "sin", "cos", "ramp" })
local k = 0
core.every(0.001, function()
  k = k + 1
  local t = k / 1000
  mon.srv:publish(topic, t, { math.sin(t), math.cos(t), t % 1 })
end)
io.stdout:write("monitor: ", mon:url(), "\n")
io.stdout:flush()

local round = 0
local function next_round()
  round = round + 1
  if round > rounds then loop:stop() return end
  io.stdout:write("phase idle\n") io.stdout:flush()
  core.after(5, function()
    io.stdout:write("phase busy\n") io.stdout:flush()
    one_run(mon, state, function() next_round() end)
  end)
end
-- the tree first (a page sees it while idle): one run configured, not started
do
  local c = fake.cluster{}
  state.sup = c:root(generated(100, 10))
  state.cluster = c
  assert(c:configure())
end
core.on_signal(function() loop:stop() end)
next_round()
loop:run()
mon:close()
