-- dca.monitor.server: the dca.monitor.v1 protocol as a page sees it (a connection stand-in records what is sent),
-- commands as console requests, bad input answered and counted, and the pages served with and without the token.
local T = require "dca.testing"
local core = require "dca.core"
local server = require "dca.monitor.server"
local suite = T.suite("monitor_server")

local loop = core.loop()

-- A page's connection: what the server sends it, decoded.
local function page()
  local p = { got = {}, subs = {} }
  function p:send(text) self.got[#self.got + 1] = core.json_decode(text) return true end
  function p:subscribe(topic, rate) self.subs[topic] = rate end
  function p:is_open() return true end
  return p
end

-- A monitor whose console requests are recorded and answered by `answer(msg)`.
local function monitor(answer)
  local asked = {}
  local mon = T.ok(server.start{ name = "main", root = "main", mode = "live", request = function(msg, cb)
    asked[#asked + 1] = msg
    cb(answer and answer(msg) or { type = "ok", output = "" })
  end })
  return mon, asked
end

-- A page gets hello and a snapshot, then deltas coalesced.
suite:case("hello_snapshot_then_coalesced_deltas", function()
  local mon = monitor(function(msg)
    if msg.type == "tree" then return { type = "ok", tree = { path = "main", kind = "group", type = "M", host = "h1",
      state = "running", children = { { path = "main.a", kind = "leaf", type = "A", host = "h2", state = "running" } } } } end
    return { type = "ok", output = "k = 1" }
  end)
  local p = page()
  mon:_open(p)
  T.eq(p.got[1].type, "hello")
  T.eq(p.got[2].type, "snapshot")
  T.eq(#p.got[2].nodes, 2)
  T.eq(p.got[2].config[1].key, "k")
  mon:line("[sim    1.500] main.a: done 1", nil)
  mon:line("[sim    1.600] main: done 1", nil)
  T.ok(loop:run_until(function() return #p.got >= 3 end, 5), "a delta came")
  local d = p.got[3]
  T.eq(d.type, "delta")
  T.eq(#d.events, 2, "both lines in one delta")
  T.eq(d.events[1].t, 1.5)
  mon:close()
end)

-- A leaf with an rt setting (the tree's rt): its node's real-time figures asked with each tree refresh (a console
-- `stats {leaf}`), sent to the page with the leaf; a leaf without one is not asked.
suite:case("real_time_figures_of_the_leaves_with_an_rt_setting_reach_the_page", function()
  local mon, asked = monitor(function(msg)
    if msg.type == "tree" then return { type = "ok", tree = { path = "main", kind = "group", type = "M", host = "h1",
      state = "running", children = { { path = "main.a", kind = "leaf", type = "A", host = "h1", state = "running",
                                        rt = true },
                                      { path = "main.b", kind = "leaf", type = "B", host = "h1", state = "running" } } } }
    end
    if msg.type == "stats" then return { type = "ok", clock = "wall", rt = { runs = 500, period_s = 0.001, overruns = 1,
      missed = 2, wake = { n = 500, p50_us = 20, p99_us = 50, max_us = 90 }, exec = { n = 500, p50_us = 3, p99_us = 5,
      max_us = 8 } } } end
    return { type = "ok", output = "" }
  end)
  local p = page()
  mon:_open(p)
  local stats = {}  -- (the tree is asked at the start and again when a page opens)
  for _, m in ipairs(asked) do if m.type == "stats" then stats[m.leaf] = (stats[m.leaf] or 0) + 1 end end
  T.eq({ stats["main.a"] ~= nil, stats["main.b"] }, { true, nil })
  T.ok(loop:run_until(function()
    for _, m in ipairs(p.got) do
      for _, n in ipairs(m.nodes or {}) do if n.path == "main.a" and n.rt then return true end end
    end
  end, 5), "a delta with main.a's figures came")
  local n = mon.model.nodes["main.a"]
  T.eq(n.rt, { runs = 500, period_s = 0.001, overruns = 1, missed = 2, wake_p50_us = 20, wake_p99_us = 50,
               wake_max_us = 90, exec_p50_us = 3, exec_p99_us = 5, exec_max_us = 8 })
  T.eq(mon.model.nodes["main.b"].rt, nil)
  mon:close()
end)

-- Commands are console requests; a config value is read as a literal, never evaluated.
suite:case("commands_are_console_requests_values_literals", function()
  local mon, asked = monitor()
  local p = page()
  mon:_message(p, core.json_encode{ type = "command", id = 1, cmd = "restart", path = "main.a" })
  mon:_message(p, core.json_encode{ type = "command", id = 2, cmd = "abort", path = "main.a" })
  mon:_message(p, core.json_encode{ type = "command", id = 3, cmd = "config_set", key = "door.w", value = "0.5" })
  mon:_message(p, core.json_encode{ type = "command", id = 4, cmd = "config_set", key = "x", value = "os.exit()" })
  local n = #asked
  T.eq(asked[n - 2], { type = "restart", path = "main.a" })
  T.eq(asked[n - 1].type, "inject")
  T.eq(asked[n - 1].msg.type, "aborted")
  T.eq(asked[n], { type = "config_set", key = "door.w", value = 0.5 })
  T.eq(p.got[#p.got].type, "reply")
  T.eq(p.got[#p.got].ok, false, "os.exit() is no literal: refused before any request")
  mon:close()
end)

-- A fleet (docs/supervision.md, "A fleet"): the page's add and remove buttons are the console's add_child and
-- remove_child requests; the tree's templates reach the page with the group's node.
suite:case("a_fleet_is_changed_by_console_requests_and_its_templates_reach_the_page", function()
  local mon, asked = monitor()
  local p = page()
  mon:_message(p, core.json_encode{ type = "command", id = 1, cmd = "add_child", path = "main.lights", host = "r2" })
  mon:_message(p, core.json_encode{ type = "command", id = 2, cmd = "remove_child", path = "main.lights_r2" })
  mon:_message(p, core.json_encode{ type = "command", id = 3, cmd = "add_child", path = "main.lights" })
  local n = #asked
  T.eq(asked[n - 1], { type = "add_child", path = "main.lights", host = "r2" })
  T.eq(asked[n], { type = "remove_child", path = "main.lights_r2" })
  T.eq(p.got[#p.got].ok, false, "an add without a host is refused before any request")
  local model = require("dca.monitor.model").new()
  model:tree({ path = "main", kind = "group", type = "main", host = "h", state = "running", children = {},
               fleet = { { template = "lights", path = "main.lights", type = "Light", hosts = { "r1", "r2" },
                           instances = { { name = "lights_r2" } } } } }, 0)
  T.eq(model.nodes.main.fleet, { { path = "main.lights", type = "Light", hosts = { "r1", "r2" }, instances = 1 } })
  model:line("main.lights_r2: running", 1)
  model:line("main.lights_r2: removed", 2)
  T.eq(model.nodes["main.lights_r2"].state, "removed", "a removed instance's row says so")
  T.eq(require("dca.supervisor.net").CONSOLE.add_child, true, "a console may send it (dca run's monitor too)")
  mon:close()
end)

-- The simulated clock (docs/time.md "Pace"): the page's clock commands are the supervisor's `clock` request (the
-- REPL's, with its checks); the world's status reaches the page as `clock`, and its time is the page's time
-- even when no line came since (paused at 3.25 s, the last line at 1 s).
suite:case("the_worlds_clock_reaches_the_page_and_its_commands_are_clock_requests", function()
  local asked = {}
  local status = { t = 3.25, running = false, speed = 2, stepping = false }
  local mon = T.ok(server.start{ name = "main", root = "main", mode = "live", world_spec = "door",
    world = function(_, cb) cb(status) end,
    request = function(msg, cb) asked[#asked + 1] = msg cb({ type = "ok", text = "t = 3.250 s, paused" }) end })
  local p = page()
  mon:line("main.a: running", 1.0)
  mon:_open(p)
  for i, c in ipairs({ { what = "pause" }, { what = "step" }, { what = "step_event" }, { what = "speed", speed = 0.5 },
                       { what = "speed", speed = "max" }, { what = "go" } }) do
    mon:_message(p, core.json_encode{ type = "command", id = i, cmd = "clock", what = c.what, speed = c.speed })
    T.eq(asked[#asked].type, "clock")
    T.eq(asked[#asked].what, c.what)
    if c.speed then T.eq(asked[#asked].speed, c.speed) end
    T.eq(p.got[#p.got], { type = "reply", id = i, ok = true, text = "t = 3.250 s, paused" })
  end
  mon:_poll_world()
  mon:_flush()
  local d = p.got[#p.got]
  T.eq(d.type, "delta")
  T.eq(d.clock, { t = 3.25, running = false, speed = 2, stepping = false })
  T.eq(d.t, 3.25, "the page's time is the world's, not the last line's (1 s)")
  local n = #p.got
  mon:_poll_world()
  mon:_flush()
  T.eq(#p.got, n, "an unchanged clock sends nothing")
  status = { t = 3.25, running = true, speed = 0, stepping = false }
  mon:_poll_world()
  mon:_flush()
  T.eq(p.got[#p.got].clock.running, true, "a clock that runs again is told though its time did not move yet")
  local q = page()
  mon:_open(q)
  T.eq(q.got[2].clock, { t = 3.25, running = true, speed = 0, stepping = false }, "a new page's snapshot has it")
  mon:close()
end)

-- Every topic is kept from its first sample (the server's hub, host/web/sample_history.h): a page that subscribes
-- late gets its rows first (the world's status, followed by the page from the start, and a port's alike); a port's topic carries its units from the manifest, one per field when the text has one each.
suite:case("a_late_page_gets_the_worlds_signals_from_the_start_and_the_ports_units", function()
  local d = require("dca.worlds").descriptor("mock:arm.urdf").topics[1]  -- /world/safety/clamps
  local status = { running = true, speed = 1, stepping = false }
  local mon = T.ok(server.start{ name = "main", root = "main", mode = "live", world_spec = "mock:arm.urdf",
    world = function(_, cb) cb(status) end, request = function(_, cb) cb({ type = "ok", output = "" }) end })
  local early = page()
  mon:_open(early)  -- (the world is polled while a page is open)
  for k = 1, 50 do
    status.t = k * 0.01
    status[d.array] = { k + 1, k + 2 }
    mon:_poll_world()
  end
  local port = mon.srv:topic("/main/b/Vel", { "value[0]", "value[1]", "value[2]" })
  mon.topic_units = function(name) return name == "/main/b/Vel" and "m/s, m/s, rad/s" or nil end
  local p = page()
  mon:_open(p)
  local topics = {}
  for _, t in ipairs(p.got[2].topics) do topics[t.name] = t end
  T.eq(topics["/main/b/Vel"].units, { "m/s", "m/s", "rad/s" })
  local w = T.ok(topics[d.topic], "the world's topic " .. d.topic)
  T.eq(w.history, true)
  mon:_message(p, core.json_encode{ type = "subscribe", topic = w.id, rate = 60 })
  local h = p.got[#p.got]
  T.eq(h.type, "history")
  T.eq(#h.rows, 50, "every status so far")
  T.eq(h.rows[1], { 0.01, 2, 3 }, "from the first")
  T.eq(p.subs[w.id], 60, "then its samples")
  for k = 1, 30 do mon.srv:publish(port, k * 0.01, { k, 0, 0 }) end
  mon:_message(p, core.json_encode{ type = "subscribe", topic = port, rate = 60 })
  h = p.got[#p.got]
  T.eq(h.type, "history")
  T.eq(#h.rows, 30, "a port picked late: every sample so far")
  T.eq(h.rows[1], { 0.01, 1, 0, 0 })
  -- the run's end: each page gets the history of every topic it did not subscribe to (kept after the server goes)
  local q = page()
  mon:_open(q)
  local before = #p.got
  mon:_histories()
  local got = {}
  for _, m in ipairs(q.got) do if m.type == "history" then got[m.topic] = #m.rows end end
  T.eq(got, { [w.id] = 50, [port] = 30 }, "the page that subscribed to nothing gets both")
  T.eq(#p.got, before, "the page that subscribed to both, none")
  T.eq(server.field_units("0 open, 1 close", 1), { "0 open, 1 close" }, "a description is every field's")
  T.eq(server.field_units("rad/s", 6), { "rad/s" })
  T.ok(port)
  mon:close()
end)

-- A refused command is answered not ok, with the supervisor's reason; an accepted config_set with what was written.
suite:case("a_refused_command_is_not_ok_and_says_why", function()
  local mon = monitor(function(msg)
    if msg.type == "config_set" and msg.key == "door.bad" then
      return { type = "error", reason = "unknown key 'door.bad' (did you mean door.width?) on host h1" }
    end
    if msg.type == "restart" and msg.path == "main.s" then
      return { type = "ok", note = "a fresh instance in shared node leaves:main@h1#42 (--placement group), with the "
        .. "code that process loaded" }
    end
    if msg.type == "restart" then return { type = "error", reason = "main.zz: no such process" } end
    return { type = "ok", text = "set 1 key: transaction 7 of h1" }
  end)
  local p = page()
  mon:_message(p, core.json_encode{ type = "command", id = 1, cmd = "config_set", key = "door.bad", value = "1" })
  T.eq(p.got[#p.got], { type = "reply", id = 1, ok = false,
                        text = "unknown key 'door.bad' (did you mean door.width?) on host h1" })
  mon:_message(p, core.json_encode{ type = "command", id = 2, cmd = "config_set", key = "door.width", value = "0.9" })
  T.eq(p.got[#p.got], { type = "reply", id = 2, ok = true, text = "set 1 key: transaction 7 of h1" })
  mon:_message(p, core.json_encode{ type = "command", id = 3, cmd = "restart", path = "main.zz" })
  T.eq(p.got[#p.got], { type = "reply", id = 3, ok = false, text = "main.zz: no such process" })
  -- a restart's note (a leaf in a shared node reuses the loaded code) is its reply's text
  mon:_message(p, core.json_encode{ type = "command", id = 4, cmd = "restart", path = "main.s" })
  T.eq(p.got[#p.got], { type = "reply", id = 4, ok = true, text = "a fresh instance in shared node "
    .. "leaves:main@h1#42 (--placement group), with the code that process loaded" })
  mon:close()
end)

-- The black box button's command: refused without --blackbox; with it, the trigger's `why` is `monitor: WHY`
-- (default "page"), never a console request, and the reply says its tick.
suite:case("the_black_box_command_names_the_monitor_and_needs_a_black_box", function()
  local mon = monitor()
  local p = page()
  mon:_message(p, core.json_encode{ type = "command", id = 1, cmd = "blackbox" })
  T.eq(p.got[#p.got], { type = "reply", id = 1, ok = false, text = "this run has no black box (dca run --blackbox)" })
  mon:close()
  local whys, asked = {}, {}
  mon = T.ok(server.start{ name = "main", root = "main", mode = "live",
    request = function(msg, cb) asked[#asked + 1] = msg.type cb({ type = "ok" }) end,
    blackbox = function(why, cb) whys[#whys + 1] = why cb({ t = 1.25 }) end })
  mon:_open(p)
  local hello
  for _, m in ipairs(p.got) do if m.type == "hello" then hello = m end end
  T.eq(hello.blackbox, true, "hello says the run has one")
  local before = #asked
  mon:_message(p, core.json_encode{ type = "command", id = 2, cmd = "blackbox" })
  T.eq(p.got[#p.got], { type = "reply", id = 2, ok = true, text = "black box triggered (monitor: page) at 1.250 s" })
  mon:_message(p, core.json_encode{ type = "command", id = 3, cmd = "blackbox", why = "the gripper slipped" })
  T.eq(whys, { "monitor: page", "monitor: the gripper slipped" })
  T.eq(#asked, before, "no console request")
  mon:close()
end)

-- The token is a viewer's credential: no command evaluates code, and one that tries reaches no console.
suite:case("no_code_evaluation", function()
  local mon, asked = monitor()
  local p = page()
  local before = #asked
  for i, cmd in ipairs({ "eval", "repl", "lua", "exec" }) do
    mon:_message(p, core.json_encode{ type = "command", id = i, cmd = cmd, line = "os.execute('true')" })
    T.eq(p.got[#p.got].type, "reply")
    T.eq(p.got[#p.got].ok, false, cmd .. " is refused")
  end
  T.eq(#asked, before, "no console request was made")
  mon:close()
end)

-- What is not JSON or not a message is answered and counted; the page's connection stays.
suite:case("bad_messages_answered_and_counted", function()
  local mon = monitor()
  local p = page()
  for _, bad in ipairs({ "", "{", "[1,2", "null", "{\"type\":\"nothing\"}", string.rep("[", 100) }) do
    mon:_message(p, bad)
    T.eq(p.got[#p.got].type, "error", bad)
  end
  T.eq(mon.errors, 6)
  mon:_message(p, core.json_encode{ type = "subscribe", topic = 3, rate = 1e9 })
  T.eq(p.subs[3], 200, "the rate is bounded")
  -- a topic that is no topic's number is answered, counted and subscribes nothing (1e308 raised in the binding)
  for _, topic in ipairs({ 1e308, -1, 2.5, "x" }) do
    mon:_message(p, core.json_encode{ type = "subscribe", topic = topic })
    T.eq(p.got[#p.got].type, "error", tostring(topic))
    T.contains(p.got[#p.got].reason, "is not a topic's number")
  end
  T.eq(mon.errors, 10)
  local n = 0
  for _ in pairs(p.subs) do n = n + 1 end
  T.eq(n, 1, "only topic 3")
  mon:close()
end)

-- curl's answer (the HTTP status) for its arguments, run while the loop serves the request.
local function http_status(args)
  local out = os.tmpname()
  local argv = { "/usr/bin/curl", "-s", "-o", "/dev/null", "-w", "%{http_code}", "-m", "5" }
  for _, a in ipairs(args) do argv[#argv + 1] = a end
  local pid = T.ok(core.spawn(argv, { stdout = out }))
  local ended
  T.ok(loop:run_until(function() ended = core.reap(pid) return ended ~= nil end, 10), "curl ended")
  local code = T.read(out)
  os.remove(out)
  return code
end

-- The page loads without the token; the WebSocket needs it.
suite:case("page_public_websocket_needs_token", function()
  local mon = monitor()
  local base = "http://" .. mon.srv:address()
  T.eq(http_status({ base .. "/" }), "200")
  T.eq(http_status({ base .. "/monitor.js" }), "200")
  local ws = { "-H", "Connection: Upgrade", "-H", "Upgrade: websocket", "-H", "Sec-WebSocket-Version: 13",
               "-H", "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==", "-H", "Sec-WebSocket-Protocol: dca.monitor.v1" }
  local function upgrade(target)
    local a = { table.unpack(ws) }
    a[#a + 1] = base .. target
    return http_status(a)
  end
  T.eq(upgrade("/ws"), "401")
  -- a key holder's token (dca monitor --token): admitted once the server is given the key
  local dir = os.tmpname()
  os.remove(dir)
  T.ok(core.make_dir(dir))
  local key_file = dir .. "/key"
  T.ok(core.write_new_file(key_file, string.rep("ab", 32) .. "\n"))
  local token = T.ok(core.monitor_token(key_file))
  T.eq(#token, 32)
  T.eq(upgrade("/ws?token=" .. token), "401", "not before the server has the key")
  T.eq(mon.srv:add_key_token(key_file), token)
  T.eq(http_status({ base .. "/monitor.js?token=" .. token }), "200")
  T.eq(core.monitor_token(dir .. "/none"), nil)
  core.remove_tree(dir)
  T.eq(upgrade("/ws?token=" .. string.rep("0", 32)), "401")
  T.eq(mon.srv:stats().refused, 3)
  T.contains(mon:url(), "?token=" .. mon.srv:token())
  mon:close()
end)

-- A URDF world's safety counts (docs/robots.md, "Safety at the port") in the monitor: live, its status's
-- safety_clamps and safety_stale (per command input, in input order) as the topics /world/safety/clamps and
-- /world/safety/stale, their fields named as the recorded channels of the same names are in a replay.
local UR10_INPUTS = 12  -- worlds/ur10/ur10.urdf: position and velocity commands of its six joints

local function safety_fields(n)
  local f = {}
  for k = 1, n do f[k] = "value[" .. (k - 1) .. "]" end
  return f
end

suite:case("a_urdf_worlds_clamp_and_stale_counts_are_live_world_topics", function()
  local status = { t = 0.5, safety_clamps = { 0, 0, 0, 0, 29, 0, 0, 0, 0, 0, 0, 0 },
                   safety_stale = { 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0 } }
  local mon = T.ok(server.start{ name = "main", root = "main", mode = "live", world_spec = "mock:arm.urdf",
                                 world = function(_, cb) cb(status) end })
  local real, published = mon.srv, {}
  mon.srv = setmetatable({ publish = function(_, id, t, v)
    published[#published + 1] = { id = id, t = t, v = v }
    return real:publish(id, t, v)
  end }, { __index = function(_, k) return function(_, ...) return real[k](real, ...) end end })
  local p = page()
  mon:_open(p)
  mon:_poll_world()
  local by_name = {}
  for _, t in ipairs(real:topics()) do by_name[t.name] = t end
  T.ok(by_name["/world/safety/clamps"] and by_name["/world/safety/stale"], "both topics offered")
  T.eq(by_name["/world/safety/clamps"].fields, safety_fields(UR10_INPUTS))
  T.eq(#published, 2)
  T.eq(published[1].id, by_name["/world/safety/clamps"].id)
  T.eq(published[1].t, 0.5)
  T.eq(published[1].v, status.safety_clamps)
  T.eq(published[2].v, status.safety_stale)
  -- the page is told of them with its next delta
  T.ok(loop:run_until(function()
    for _, m in ipairs(p.got) do
      for _, t in ipairs(m.topics or {}) do if t.name == "/world/safety/stale" then return true end end
    end
  end, 5), "the topics reach the page")
  mon.srv = real
  mon:close()
end)

-- The same counts in a replay: a recorded clamped run of the mock UR10 (its target beyond the elbow's limit)
-- has /world/safety/clamps with the live topic's fields, the elbow's position command's count reaching the end's.
suite:case("a_urdf_worlds_clamp_counts_replay_under_the_live_topics_names", function()
  local file = T.src .. "/tests/lua/launch/systems/elbow_beyond_limit.dca"
  local mcap = T.tmpname(".mcap")
  local out = T.sh("timeout 120 " .. T.exe .. " run " .. file .. " --sim 'mock:" .. T.src .. "/worlds/ur10/ur10.urdf'"
                   .. " --record " .. mcap)
  T.contains(out, "joint.elbow_joint.position_command: 29 of 29 samples clamped")
  local rec = T.ok(require("dca.monitor.replay").load(mcap))
  local clamps, stale
  for _, s in ipairs(rec.series) do
    if s.name == "/world/safety/clamps" then clamps = s end
    if s.name == "/world/safety/stale" then stale = s end
  end
  T.ok(clamps and stale, "both recorded")
  T.eq(clamps.fields, safety_fields(UR10_INPUTS))
  T.eq(stale.fields, safety_fields(UR10_INPUTS))
  -- value[4], the elbow's position command (after the row's time): counted up, reaching the summary's 29 (rows
  -- after the run's end depend on the wall clock: time runs on while the tree stops, so the last may count more)
  local reached, prev = false, 0
  for _, row in ipairs(clamps.rows) do
    T.ok(row[1 + 5] >= prev, "the count never goes down")
    prev = row[1 + 5]
    reached = reached or prev == 29
  end
  T.ok(reached, "a row with the elbow's 29 clamps")
  T.cleanup()
end)

return suite:run(...)
