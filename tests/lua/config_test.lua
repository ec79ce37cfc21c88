-- dca.config and `dca config` against real `dca daemon` processes on loopback (hosts A, B, C on 127.0.0.1, .2,
-- .3), each with its own state directory: replication, a partition with a conflicting write, kill -9 during a
-- write burst, a corrupt database, and the command line.
local T = require "dca.testing"
local core = require "dca.core"
local config = require "dca.config"
local suite = T.suite("config")

local loop, DCA = core.loop(), T.exe
local function wait(pred, what, seconds) T.wait(loop, pred, what, seconds or 20) end

local function sh_quote(s) return "'" .. tostring(s):gsub("'", "'\\''") .. "'" end

-- A `dca daemon` started with io.popen; returns { addr, pid, pipe, host, dir }.
local function start_daemon(host, listen, key_file, state_dir, peers)
  local extra = ""
  for _, p in ipairs(peers or {}) do extra = extra .. " --peer " .. p end
  local cmd = string.format("%s daemon --host %s --listen %s --key %s --state-dir %s --sync-ms 100 --grace 200%s & echo $!",
    DCA, host, listen, sh_quote(key_file), sh_quote(state_dir), extra)
  local p = assert(io.popen(cmd, "r"))
  local l1, l2 = p:read("l") or "", p:read("l") or ""
  local pid, line = l1, l2
  if l1:match("listening on") then pid, line = l2, l1 end
  local addr = line:match("listening on (%S+)")
  T.ok(addr, "daemon " .. host .. " said: " .. line)
  return { addr = addr, pid = tonumber(pid), pipe = p, host = host, dir = state_dir, key = key_file }
end

local function gone(pid)
  local f = io.open("/proc/" .. pid .. "/stat", "r")
  if not f then return true end
  local st = f:read("l") or ""
  f:close()
  return st:match("^%d+ %b() Z") ~= nil
end

-- Stops a daemon and waits (bounded) until its process is gone, so that its state directory is free again.
local function stop_daemon(d, signal)
  if d.stopped then return end
  d.stopped = true
  os.execute("kill -" .. (signal or "TERM") .. " " .. d.pid .. " 2>/dev/null")
  d.pipe:close()
  local deadline = core.now() + 10
  while not gone(d.pid) and core.now() < deadline do os.execute("sleep 0.02") end
  T.ok(gone(d.pid), "daemon " .. d.host .. " (pid " .. d.pid .. ") did not exit within 10 s")
end

local function connect(d)
  local done, c, err = false, nil, nil
  config.connect(d.addr, { key_file = d.key }, function(x, e) done, c, err = true, x, e end)
  wait(function() return done end, "connect to " .. d.host)
  T.ok(c, err)
  return c
end

-- Calls fn(cb) and waits for cb(a, b, c); returns them.
local function call(what, fn)
  local done, a, b, c = false, nil, nil, nil
  fn(function(x, y, z) done, a, b, c = true, x, y, z end)
  wait(function() return done end, what)
  return a, b, c
end

local function get(c, key)
  local v, err = call("get " .. key, function(k) c:get(key, k) end)
  return v, err
end

-- Waits until every client reads key = value.
local function everywhere(clients, key, value)
  wait(function()
    for _, c in ipairs(clients) do
      local v = get(c, key)
      if not T.equal(v, value) then return false end
    end
    return true
  end, key .. " = " .. tostring(value) .. " everywhere")
end

local function listing(c)
  local entries = assert(call("list", function(k) c:list("", k) end))
  local out = {}
  for _, e in ipairs(entries) do out[#out + 1] = e.key .. "=" .. T.show(e.value) .. "@" .. e.stamp.origin end
  return table.concat(out, "\n")
end

local function fresh_key()
  local dir = T.tmpdir()
  return dir .. "/key", dir
end

-- Runs body(ctx) with daemons cleaned up afterwards.
local function with_cluster(body)
  local ctx = { daemons = {}, dirs = {} }
  ctx.key, ctx.keydir = fresh_key()
  ctx.start = function(host, listen, peers, dir)
    local d = start_daemon(host, listen, ctx.key, dir or (ctx.keydir .. "/" .. host), peers)
    ctx.daemons[#ctx.daemons + 1] = d
    return d
  end
  local ok, err = pcall(body, ctx)
  for _, d in ipairs(ctx.daemons) do stop_daemon(d) end
  os.execute("rm -rf " .. sh_quote(ctx.keydir))
  if not ok then error(err, 0) end
end

suite:case("three_daemons_a_write_on_each_reaches_all_and_watches_fire", function()
  with_cluster(function(ctx)
    local C = ctx.start("C", "127.0.0.3:0")
    local B = ctx.start("B", "127.0.0.2:0", { C.addr })
    local A = ctx.start("A", "127.0.0.1:0", { B.addr, C.addr })
    local a, b, c = connect(A), connect(B), connect(C)
    local events = {}
    T.ok(call("watch", function(k) c:watch("door", function(ev) events[#events + 1] = ev end, k) end))
    T.ok(call("set on A", function(k) a:set({ ["door.width"] = 0.9, ["door.stop_distance"] = 0.45 }, k) end))
    T.ok(call("set on B", function(k) b:set({ ["robot.arm.gains.kp"] = 12 }, k) end))
    local r = T.ok(call("set on C", function(k) c:set({ ["robot.name"] = "puma", ["robot.limits"] = { 1, 2.5, 3 } }, k) end))
    T.eq(r.keys, 2)
    T.eq(r.seq, 1)
    everywhere({ a, b, c }, "door.width", 0.9)
    everywhere({ a, b, c }, "robot.arm.gains.kp", 12)
    everywhere({ a, b, c }, "robot.limits", { 1, 2.5, 3 })
    T.eq(listing(a), listing(b))
    T.eq(listing(a), listing(c))
    wait(function() return #events >= 2 end, "two config_changed events at C")
    local keys = {}
    for _, ev in ipairs(events) do keys[#keys + 1] = ev.key end
    table.sort(keys)
    T.eq(keys, { "door.stop_distance", "door.width" }, "C's watch of door: A's replicated writes only")
    T.eq(events[1].origin:match("^A/") ~= nil, true, "origin is A's replica: " .. tostring(events[1].origin))
    -- An unknown key: a clear error with the close names.
    local v, err = get(b, "door.widht")
    T.eq(v, nil)
    T.eq(err, "unknown key 'door.widht' (did you mean door.width?) on host B")
  end)
end)

suite:case("partition_both_sides_write_the_same_key_heal_converge_conflict_logged", function()
  with_cluster(function(ctx)
    local C = ctx.start("C", "127.0.0.3:0")
    local B = ctx.start("B", "127.0.0.2:0", { C.addr })
    local A = ctx.start("A", "127.0.0.1:0", { B.addr, C.addr })
    local a, b = connect(A), connect(B)
    T.ok(call("first", function(k) a:set({ ["door.stop_distance"] = 0.5 }, k) end))
    local c = connect(C)
    everywhere({ a, b, c }, "door.stop_distance", 0.5)
    -- C leaves: stopped, then back at another address its peers do not know (cut off), where it takes writes.
    c:close()
    stop_daemon(C)
    T.ok(call("A writes", function(k) a:set({ ["door.stop_distance"] = 0.4, ["a.side"] = 1 }, k) end))
    local C2 = ctx.start("C", "127.0.0.3:0", {}, C.dir)
    T.ok(C2.addr ~= C.addr, "C restarted elsewhere")
    local c2 = connect(C2)
    T.eq((get(c2, "door.stop_distance")), 0.5, "C kept its replica")
    os.execute("sleep 0.05")  -- C's write must be the later one: the stamps are wall-clock milliseconds
    T.ok(call("C writes", function(k) c2:set({ ["door.stop_distance"] = 0.3, ["c.side"] = 2 }, k) end))
    c2:close()
    stop_daemon(C2)
    -- Healed: C back at its own address; its peers reconnect and the replicas converge.
    local C3 = ctx.start("C", C.addr, {}, C.dir)
    local c3 = connect(C3)
    everywhere({ a, b, c3 }, "door.stop_distance", 0.3)
    everywhere({ a, b, c3 }, "a.side", 1)
    everywhere({ a, b, c3 }, "c.side", 2)
    T.eq(listing(a), listing(b))
    T.eq(listing(a), listing(c3))
    for name, cl in pairs({ A = a, B = b, C = c3 }) do
      local log = T.ok(call("log " .. name, function(k) cl:log(10, k) end))
      T.eq(#log.conflicts, 1, name .. "'s conflicts: " .. T.show(log.conflicts))
      local x = log.conflicts[1]
      T.eq(x.key, "door.stop_distance")
      T.eq(x.loser.value, 0.4)
      T.eq(x.winner.value, 0.3)
      T.ok(x.loser.stamp.origin:match("^A/"), "the loser was A's write")
    end
  end)
end)

suite:case("kill9_during_a_write_burst_every_acknowledged_write_is_there_after_restart", function()
  with_cluster(function(ctx)
    local A = ctx.start("A", "127.0.0.1:0")
    local a = connect(A)
    local acked, sent, closed = {}, 0, false
    a:on_close(function() closed = true end)
    local function send_one()
      if closed or sent >= 100000 then return end
      sent = sent + 1
      local i = sent
      a:set({ ["burst.n" .. i] = i, ["burst.last"] = i }, function(r)
        if r then
          acked[#acked + 1] = i
          send_one()
        end
      end)
    end
    for _ = 1, 4 do send_one() end  -- four writes in flight at any time
    wait(function() return #acked >= 300 end, "300 acknowledged writes", 120)
    stop_daemon(A, "KILL")
    wait(function() return closed end, "the channel to close")
    T.ok(#acked >= 300 and sent > #acked, "writes were in flight when it died")
    local A2 = ctx.start("A", "127.0.0.1:0", {}, A.dir)
    local a2 = connect(A2)
    local entries = assert(call("list", function(k) a2:list("burst", k) end))
    local have = {}
    for _, e in ipairs(entries) do have[e.key] = e.value end
    local missing = {}
    for _, i in ipairs(acked) do
      if have["burst.n" .. i] ~= i then missing[#missing + 1] = i end
    end
    T.eq(missing, {}, "acknowledged writes missing after kill -9")
    local max = 0
    for _, i in ipairs(acked) do if i > max then max = i end end
    T.ok(have["burst.last"] >= max, "burst.last " .. tostring(have["burst.last"]) .. " >= " .. max)
  end)
end)

suite:case("a_corrupt_database_stops_the_daemon_naming_the_file", function()
  local dir = T.tmpdir()
  local f = assert(io.open(dir .. "/config.db", "wb"))
  f:write(string.rep("not a database ", 500))
  f:close()
  local key = dir .. "/key"
  local out, code = T.sh(string.format("timeout 20 %s daemon --host X --key %s --state-dir %s", DCA, sh_quote(key),
    sh_quote(dir)))
  os.execute("rm -rf " .. sh_quote(dir))
  T.eq(code, 1, out)
  T.contains(out, "configuration database " .. dir .. "/config.db is not usable")
  T.contains(out, "file is not a database")
  T.ok(not out:find("listening on"), "it did not start: " .. out)
end)

suite:case("command_line_get_set_list_log_status", function()
  with_cluster(function(ctx)
    local B = ctx.start("B", "127.0.0.2:0")
    local A = ctx.start("A", "127.0.0.1:0", { B.addr })
    local function dca(args)
      return T.sh(string.format("%s config %s --daemon %s --key %s", DCA, args, A.addr, sh_quote(ctx.key)))
    end
    local out, code = dca("set door.width=0.9 robot.name=puma 'robot.limits={1, 2}' door.open=true")
    T.eq(code, 0, out)
    T.contains(out, "set 4 keys: transaction 1 of A/")
    out, code = dca("get door.width")
    T.eq(code, 0, out)
    T.eq(out, "0.9\n")
    out = dca("get robot.limits")
    T.eq(out, "{ 1, 2 }\n")
    out, code = dca("list robot")
    T.eq(code, 0, out)
    T.eq(out, "robot.limits = { 1, 2 }\nrobot.name = \"puma\"\n")
    out, code = dca("get door.widht")
    T.eq(code, 1)
    T.eq(out, "dca config: unknown key 'door.widht' (did you mean door.width?) on host A\n")
    out, code = dca("set 'door..x=1'")
    T.eq(code, 1)
    T.contains(out, "bad key 'door..x': empty name at byte 6")
    out, code = dca("log 5")
    T.eq(code, 0, out)
    T.contains(out, "replica A/")
    T.contains(out, "door.open = true, door.width = 0.9, robot.limits = { 1, 2 }, robot.name = \"puma\"")
    T.contains(out, "conflicts, newest first: none")
    -- replicated to B
    local b = connect(B)
    everywhere({ b }, "robot.name", "puma")
    out, code = dca("status")
    T.eq(code, 0, out)
    T.contains(out, "peer " .. B.addr .. ": connected")
    out, code = dca("frobnicate")
    T.eq(code, 2)
    T.contains(out, "unknown command 'frobnicate'")
    out, code = T.sh(string.format("%s config get a.b --daemon 127.0.0.1:1 --key %s", DCA, sh_quote(ctx.key)))
    T.eq(code, 1)
    T.contains(out, "cannot reach the daemon at 127.0.0.1:1")
  end)
end)

suite:case("resolve_params_replaces_config_parameters_and_names_process_parameter_and_key", function()
  local values = { ["door.stop_distance"] = 0.45, ["door.name"] = "front" }
  local fake = {
    get = function(_, key, cb)
      if values[key] ~= nil then cb(values[key]) else cb(nil, "unknown key '" .. key .. "' on host h2") end
    end,
  }
  local out, err = call("resolve", function(k)
    config.resolve_params({ 1.5, { config = "door.stop_distance" }, "config:door.name", n = 3 }, fake, k)
  end)
  T.eq(err, nil)
  T.eq(out, { 1.5, 0.45, "front", n = 3 })
  out, err = call("resolve bad type", function(k)
    config.resolve_params({ { config = "door.name" } }, fake, k,
      { process = "main.door.det", host = "h2", params = { "threshold" } }, { "number" })
  end)
  T.eq(out, nil)
  T.eq(err, "process main.door.det on host h2: parameter 1 'threshold' (config key 'door.name'): the value \"front\" is "
    .. "a string, not a number")
  out, err = call("resolve unknown", function(k)
    config.resolve_params({ 0, { config = "door.stop_distanse" } }, fake, k, { process = "main.x" })
  end)
  T.eq(out, nil)
  T.eq(err, "process main.x: parameter 2 (config key 'door.stop_distanse'): unknown key 'door.stop_distanse' on host h2")
  -- Nothing to resolve: the same values, at once.
  out = call("resolve none", function(k) config.resolve_params({ 1, "x" }, fake, k) end)
  T.eq(out, { 1, "x" })
end)

suite:case("a_dca_parameter_config_key_is_read_from_a_daemon_at_start", function()
  local parser = require "dca.lang.parser"
  local model = require "dca.lang.model"
  local text = [[
process main() {
  host { "h1" }
  instantiated_processes {
    det instof DistanceThreshold("h1", config("door.stop_distance"), 2);
    cnt instof Counter("h1", config("door.period"));
  }
  internal_event_actions { det }
}
]]
  local ast = assert(parser.parse(text, "cfg.dca"))
  local manifest = { params = { { name = "threshold", type = "number" }, { name = "hold", type = "number" } } }
  local tree, errs = model.build(ast, { manifest = function(t)
    if t == "DistanceThreshold" then return manifest end
    return { params = { { name = "period", type = "number" } } }
  end })
  T.ok(tree, errs and T.show(errs))
  local det = tree.children.det
  T.eq(det.params, { { config = "door.stop_distance" }, 2 })
  with_cluster(function(ctx)
    local A = ctx.start("A", "127.0.0.1:0")
    local a = connect(A)
    T.ok(call("set", function(k) a:set({ ["door.stop_distance"] = 0.45, ["door.period"] = "fast" }, k) end))
    local out, err = call("resolve det", function(k)
      config.resolve_params(det.params, a, k, { process = det.path, host = det.host, params = det.manifest.params })
    end)
    T.eq(err, nil)
    T.eq(out, { 0.45, 2 })
    local cnt = tree.children.cnt
    out, err = call("resolve cnt", function(k)
      config.resolve_params(cnt.params, a, k, { process = cnt.path, host = cnt.host, params = cnt.manifest.params })
    end)
    T.eq(out, nil)
    T.eq(err, "process main.cnt on host h1: parameter 1 'period' (config key 'door.period'): the value \"fast\" is a "
      .. "string, not a number")
  end)
end)

-- Values are data: KEY=VALUE and defaults files are read by dca.literal, never executed.
-- bounded(fn, ...) runs fn with an instruction budget: a value that loops fails the case instead of hanging it.
local function bounded(fn, ...)
  local co = coroutine.create(fn)
  debug.sethook(co, function() error("instruction budget exhausted: the value was executed?") end, "", 10000000)
  local r = table.pack(coroutine.resume(co, ...))
  T.ok(r[1], tostring(r[2]))
  return table.unpack(r, 2, r.n)
end

-- Values built in Lua are held to the literal grammar before anything is sent: inf and NaN, functions, and a
-- table nested past the bound are refused with the reason (the client raised on a table nested 100 deep).
suite:case("the_client_refuses_values_that_are_no_literal_with_the_reason_and_sends_nothing", function()
  local sent = 0
  local c = require("dca.clients.config").over_channel({ request = function() sent = sent + 1 end }, 1)
  local deep = {}
  for _ = 1, 100 do deep = { deep } end
  for _, case in ipairs({
    { { x = math.huge }, "config set x: a number must be finite, got inf" },
    { { x = -math.huge }, "config set x: a number must be finite, got -inf" },
    { { x = 0 / 0 }, "config set x: a number must be finite, got " },
    { { x = { 1, { 2, 0 / 0 } } }, "config set x: a number must be finite" },
    { { x = print }, "config set x: a value is a number, a string, a boolean or a table, not a function" },
    { { x = deep }, "config set x: tables nest at most 32 deep" },
    { { x = { [{}] = 1 } }, "config set x: a table key must be a number, a string or a boolean" },
  }) do
    local r, err
    c:set(case[1], function(a, b) r, err = a, b end)
    T.eq(r, nil)
    T.contains(err, case[2])
  end
  T.eq(sent, 0, "nothing was sent")
  T.ok(require("dca.literal").check({ 1, 2.5, "x", true, { a = { b = -3 } } }))
end)

suite:case("parse_assignment_reads_literals_keeps_plain_words_and_refuses_code", function()
  local function pa(text) return table.pack(config.parse_assignment(text)) end
  T.eq(pa("door.width=0.9"), { "door.width", 0.9, n = 2 })
  T.eq(pa("a.n=-3"), { "a.n", -3, n = 2 })
  T.eq(pa('a.s="x = 1"'), { "a.s", "x = 1", n = 2 })
  T.eq(pa("a.t={1, b = {true}}"), { "a.t", { 1, b = { true } }, n = 2 })
  for _, word in ipairs({ "right", "10.0.0.2", "/tmp/x", "-x", "os.exit", "1+1", "" }) do
    T.eq(pa("door.side=" .. word), { "door.side", word, n = 2 }, "the plain word " .. word)
  end
  for _, c in ipairs({ { "x=os.exit(3)", 3, "'os' is not a value" },
                       { "x=(function() while true do end end)()", 3, "found '('" },
                       { "x={1,,2}", 6, "found ','" }, { 'x="open', 3, "unfinished string" },
                       { "x=[", 3, "found '['" } }) do
    local k, err = bounded(config.parse_assignment, c[1])
    T.eq(k, nil, c[1])
    T.contains(err, c[1] .. ": column " .. c[2] .. ": ")
    T.contains(err, c[3])
  end
  T.eq(pa("nothing"), { nil, "expected KEY=VALUE, got 'nothing'", n = 2 })
end)

suite:case("read_file_reads_literals_and_names_the_column_of_code", function()
  local path = T.tmpfile('# defaults\na = 0.5   # seconds\nb = "x # y" -- text\nc = {1, {2}, k = false}\n'
    .. "d = 0x10\n", ".config")
  T.eq(config.read_file(path), { { key = "a", value = 0.5, line = 2 }, { key = "b", value = "x # y", line = 3 },
    { key = "c", value = { 1, { 2 }, k = false }, line = 4 }, { key = "d", value = 16, line = 5 } })
  for _, c in ipairs({ { "x = (function() while true do end end)()", "1:5:", "found '('" },
                       { "ok = 1\n  y =  os.exit(3)", "2:8:", "'os' is not a value" },
                       { "z = {1, 2, f()}", "1:12:", "'f' is not a value" },
                       { "w = 1 2", "1:7:", "unexpected '2' after the value" } }) do
    T.write(path, c[1] .. "\n")
    local v, err = bounded(config.read_file, path)
    T.eq(v, nil, c[1])
    T.contains(err, path .. ":" .. c[2] .. " the value of ")
    T.contains(err, c[3])
  end
  os.remove(path)
end)

return suite:run(...)
