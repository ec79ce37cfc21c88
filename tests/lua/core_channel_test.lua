-- dca.core's channels from Lua: core.listen / core.connect, messages as tables, request/reply with timeouts,
-- close events, refused keys; and dca.clients.daemon against a real `dca daemon`.
local T = require "dca.testing"
local core = require "dca.core"
local daemon_client = require "dca.clients.daemon"
local suite = T.suite("core_channel")

local loop = core.loop()
local KEY = "0123456789abcdef0123456789abcdef"
local DCA = T.exe

-- An echo server on a fresh port: replies to every request with its message; closes on "bye".
local function echo_server(opts)
  local server = { channels = {}, closed = {}, refused = {} }
  opts = opts or {}
  local l, err = core.listen(opts.addr or "127.0.0.1:0", {
    key = opts.key or KEY,
    on_refused = function(why) server.refused[#server.refused + 1] = why end,
  }, function(ch)
    server.channels[#server.channels + 1] = ch
    ch:on_message(function(msg, id)
      if msg.type == "bye" then return ch:close("bye") end
      if id > 0 and msg.type ~= "silent" then ch:reply(id, msg) end
    end)
    ch:on_close(function(why) server.closed[#server.closed + 1] = why end)
  end)
  T.ok(l, err)
  server.listener = l
  return server
end

local function connect(addr, opts)
  local got, err
  local done = false
  core.connect(addr, opts or { key = KEY }, function(ch, e)
    got, err, done = ch, e, true
  end)
  T.ok(loop:run_until(function() return done end, 10), "connect finished")
  return got, err
end

-- A case body run with a channel to a fresh echo server; both are closed after it.
local function with_echo_channel(body)
  return function()
    local s = echo_server()
    local ch = T.ok(connect(s.listener:address()))
    body(ch, s)
    ch:close()
    s.listener:close()
  end
end

local function call(ch, msg, timeout)
  local r, done = nil, false
  ch:request(msg, timeout or 5, function(...) r, done = table.pack(...), true end)
  T.ok(loop:run_until(function() return done end, 15), "request answered")
  return table.unpack(r, 1, r.n)
end

suite:case("tables_cross_as_msgpack_maps", with_echo_channel(function(ch)
  T.contains(tostring(ch), "dca.Channel(127.0.0.1:")
  local msg = {
    type = "echo", int = 42, neg = -7, big = math.maxinteger, float = 2.5, str = "a\0b", yes = true, no = false,
    list = { 1, 2, 3, "four" }, nested = { a = { b = { c = { 1.5 } } } }, holes = { [1] = "x", [3] = "z" },
    empty = {},
  }
  local reply, err = call(ch, msg)
  T.ok(reply, err)
  msg.type = "ok"
  T.eq(reply, msg)
  T.eq(math.type(reply.int), "integer")
  T.eq(math.type(reply.float), "float")
  T.eq(reply.holes[2], nil)
end))

suite:case("unsendable_values_are_refused_with_their_path", with_echo_channel(function(ch)
  T.contains(T.raises(ch.send, ch, { type = "x", f = print }), "msg.f: cannot send a function")
  T.contains(T.raises(ch.send, ch, { type = "x", list = { 1, { coroutine.create(print) } } }), "msg.list[2][1]")
  local cyc = { type = "x" }
  cyc.self = cyc
  T.contains(T.raises(ch.send, ch, cyc), "nested deeper")
  T.contains(T.raises(ch.send, ch, { no_type = 1 }), "needs a non-empty string field 'type'")
end))

suite:case("request_times_out_and_channel_stays_open", with_echo_channel(function(ch)
  local reply, err = call(ch, { type = "silent" }, 0.05)
  T.eq(reply, nil)
  T.contains(err, "timeout: no reply to 'silent'")
  T.ok(ch:is_open())
end))

suite:case("error_replies_give_nil_reason_and_reply", function()
  local l = T.ok(core.listen("127.0.0.1:0", { key = KEY }, function(ch)
    ch:on_message(function(_, id) ch:reply_error(id, "not today") end)
  end))
  local ch = T.ok(connect(l:address()))
  local reply, err, full = call(ch, { type = "anything" })
  T.eq(reply, nil)
  T.eq(err, "not today")
  T.eq(full.type, "error")
  ch:close()
  l:close()
end)

suite:case("requests_carry_their_id_and_reply_takes_the_request", function()
  local seen = {}
  local l = T.ok(core.listen("127.0.0.1:0", { key = KEY }, function(ch)
    ch:on_message(function(msg, id)
      seen[#seen + 1] = { type = msg.type, id = msg.id, arg = id }
      if msg.type == "good" then ch:reply(msg, { type = "ok", answer = 42 }) end
      if msg.type == "bad" then ch:reply(msg, { type = "error", reason = "bad request", detail = 1 }) end
    end)
  end))
  local ch = T.ok(connect(l:address()))
  ch:send({ type = "event" })
  local reply = call(ch, { type = "good" })
  T.eq(reply, { type = "ok", answer = 42 })
  local r2, err, full = call(ch, { type = "bad" })
  T.eq(r2, nil)
  T.eq(err, "bad request")
  T.eq(full.detail, 1)
  T.eq(seen[1], { type = "event", arg = 0 })
  T.eq(seen[2].type, "good")
  T.ok(seen[2].id > 0 and seen[2].id == seen[2].arg)
  T.contains(T.raises(ch.send, ch, { type = "x", id = -1 }), "'id' must be a non-negative integer")
  ch:close()
  l:close()
end)

suite:case("peer_close_is_an_event_and_fails_pending_requests", function()
  local s = echo_server()
  local ch = T.ok(connect(s.listener:address()))
  local why
  ch:on_close(function(reason) why = reason end)
  local pending_err
  ch:request({ type = "silent" }, 30, function(_, err) pending_err = err end)
  ch:send({ type = "bye" })
  T.ok(loop:run_until(function() return why ~= nil and pending_err ~= nil end, 10))
  T.contains(why, "closed by the peer")
  T.contains(pending_err, "closed")
  T.eq(ch:is_open(), false)
  T.eq(ch:send({ type = "x" }), false)
  s.listener:close()
end)

suite:case("wrong_key_is_refused_on_both_sides", function()
  local s = echo_server()
  local ch, err = connect(s.listener:address(), { key = "another key that is 32 bytes...." })
  T.eq(ch, nil)
  T.contains(err, "key check")
  T.ok(loop:run_until(function() return #s.refused > 0 end, 10))
  T.contains(s.refused[1], "wrong cluster key")
  T.eq(#s.channels, 0)
  s.listener:close()
end)

suite:case("unix_socket_channels", function()
  local path = T.tmpname(".sock")
  local s = echo_server({ addr = "unix:" .. path })
  local ch = T.ok(connect("unix:" .. path))
  local reply = call(ch, { type = "echo", n = 1 })
  T.eq(reply.n, 1)
  ch:close()
  s.listener:close()
end)

suite:case("bad_address_is_an_argument_error", function()
  T.contains(T.raises(core.connect, "nowhere", {}, function() end), "bad address 'nowhere'")
  local l, err = core.listen("127.0.0.1:1", { key = KEY }, function() end)
  if l then l:close() else T.contains(err, "cannot listen on 127.0.0.1:1") end
end)

-- A `dca daemon` started with io.popen; returns its address, pid and key file.
local function start_daemon(host, extra)
  local key_file = T.tmpname(".key")  -- the daemon creates it (mode 0600)
  local cmd = string.format("%s daemon --host %s --key %s --grace 100 %s & echo $!", DCA, host, key_file, extra or "")
  local p = assert(io.popen(cmd, "r"))
  local pid = p:read("l")
  local line = p:read("l") or ""
  local addr = line:match("listening on (%S+)")
  T.ok(addr, "daemon said: " .. line)
  return { addr = addr, pid = tonumber(pid), key_file = key_file, pipe = p }
end

local function stop_daemon(d)
  os.execute("kill " .. d.pid)
  d.pipe:close()
  os.remove(d.key_file)
end

suite:case("daemon_client_spawns_and_gets_exit_events", function()
  local d = start_daemon("lh", "--allow /bin/sh")
  local client, err
  daemon_client.connect(d.addr, { key_file = d.key_file }, function(c, e) client, err = c, e end)
  T.ok(loop:run_until(function() return client or err end, 10))
  T.ok(client, err)
  local events = {}
  local spawned, exits = {}, {}
  client:on_exit(function(ev) exits[#exits + 1] = ev end)
  client:spawn({ "/bin/sh", "-c", "exit 3" }, { name = "three", on_exit = function(ev) events.three = ev end },
    function(r, e) spawned.three = r or e end)
  client:spawn({ "/bin/sh", "-c", "ulimit -c 0; kill -SEGV $$" }, { on_exit = function(ev) events.segv = ev end },
    function(r, e) spawned.segv = r or e end)
  client:spawn({ "/bin/sh", "-c", "exec sleep 100" }, { on_exit = function(ev) events.killed = ev end },
    function(r, e)
      spawned.killed = r or e
      if r then client:kill(r.child, "SIGKILL") end
    end)
  T.ok(loop:run_until(function() return events.three and events.segv and events.killed end, 20))
  T.eq(events.three.code, 3)
  T.eq(events.three.name, "three")
  T.eq(events.three.host, "lh")
  T.eq(events.segv.signal, "SIGSEGV")
  T.eq(events.killed.signal, "SIGKILL")
  T.eq(#exits, 3)
  -- refused spawn
  local refused
  client:spawn({ "/bin/rm", "-rf", "/" }, {}, function(r, e) refused = e end)
  T.ok(loop:run_until(function() return refused end, 10))
  T.contains(refused, "not allowed")
  -- names
  local reg, found
  client:register("/lua/thing", { control = "x" }, function(r, e) reg = r or e end)
  client:lookup("/lua/thing", {}, function(r, e) found = r or e end)
  T.ok(loop:run_until(function() return reg and found end, 10))
  T.eq(found.endpoints.control, "x")
  T.eq(found.host, "lh")
  local closed
  client:on_close(function(why) closed = why end)
  stop_daemon(d)
  T.ok(loop:run_until(function() return closed end, 10))
  T.contains(closed, "stopped")
end)

return suite:run(...)
