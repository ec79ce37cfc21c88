-- dca.clients: one wrap of a channel, one timeout policy, one lookup (against a channel that records).
local T = require "dca.testing"
local clients = require "dca.clients"
local suite = T.suite("clients")

-- A channel double: records requests, answers with `answer(msg)` at once.
local function channel(answer)
  local ch = { sent = {} }
  function ch:request(msg, timeout, cb)
    self.sent[#self.sent + 1] = { msg = msg, timeout = timeout }
    cb(answer(msg))
  end
  function ch:on_message(fn) self.message_fn = fn end
  function ch:on_close(fn) self.close_fn = fn end
  return ch
end

suite:case("a_request_waits_the_one_timeout_unless_the_client_says_otherwise", function()
  local ch = channel(function() return { type = "ok" } end)
  local c = clients.wrap(ch, clients.Plain)
  c:request({ type = "ping" })
  c:request({ type = "ping" }, 2)
  T.eq(ch.sent[1].timeout, clients.TIMEOUT)
  T.eq(ch.sent[2].timeout, 2)
  T.eq(clients.wrap(channel(function() end), clients.Plain, { request_timeout = 9 }).timeout, 9)
end)

suite:case("a_lookup_waits_its_wait_plus_the_timeout_and_gives_the_endpoints", function()
  local ch = channel(function(msg)
    if msg.name == "main.a" then return { type = "ok", endpoints = { control = "127.0.0.1:1" } } end
    return nil, "no process 'main.b' registered"
  end)
  local d = clients.wrap(ch, clients.Plain)
  local ep, err
  clients.lookup(d, "main.a", 2, function(e, x) ep, err = e, x end)
  T.eq(ep, { control = "127.0.0.1:1" })
  T.eq(ch.sent[1].msg, { type = "lookup", name = "main.a", wait_ms = 2000 })
  T.eq(ch.sent[1].timeout, 2 + clients.TIMEOUT)
  clients.lookup(d, "main.b", 0, function(e, x) ep, err = e, x end)
  T.eq({ ep, err }, { nil, "no process 'main.b' registered" })
end)

suite:case("an_error_reply_is_nil_and_its_reason", function()
  local got
  clients.result(function(...) got = table.pack(...) end)({ type = "error", reason = "no such port" })
  T.eq({ got[1], got[2] }, { nil, "no such port" })
  clients.result(function(...) got = table.pack(...) end)({ type = "ok", value = 1 })
  T.eq(got[1], { type = "ok", value = 1 })
end)

suite:case("events_reach_the_class_and_the_close_is_remembered", function()
  local ch = channel(function() end)
  local Class = clients.class({ _event = function(self, msg) self.got = msg end })
  local c = clients.wrap(ch, Class)
  ch.message_fn({ type = "done" }, 0)
  T.eq(c.got, { type = "done" })
  local reason
  c:on_close(function(r) reason = r end)
  ch.close_fn("peer gone")
  T.eq({ c.closed, reason }, { "peer gone", "peer gone" })
end)

return suite:run(...)
