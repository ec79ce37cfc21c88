-- Live parameters (dca.supervisor.live) on the in-memory cluster: a change of a key of the repository reaches
-- the leaves whose argument is config("that key"), in this group and below: a live parameter with `set_param`
-- and a line at the leaf; one that is not live with a line saying it applies at the leaf's next start; a refusal
-- said with the controller's reason, the leaf running on.
local T, fake = require "dca.testing", require "dca.supervisor.memory"
local suite = T.suite("supervisor_live")

local leaf, group, root = fake.leaf, fake.group, fake.root

local function with_params(l, params)
  l.params = params
  return l
end

-- main: g (Gain, k = config("test.k"), live), t (Timer, seconds = config("test.wait"), not live), w (no key);
-- sub: g2 (Gain, k = config("test.k") too).
local function system()
  local k = { { name = "k", type = "number", live = true }, { name = "period", type = "number" } }
  local sub = group("sub", "Sub", "h2", "g2", { with_params(leaf("g2", "Gain", "h2", { { config = "test.k" } }), k) })
  return root("main", "h1", "g , t , w , sub", {
    with_params(leaf("g", "Gain", "h1", { { config = "test.k" } }), k),
    with_params(leaf("t", "Timer", "h1", { { config = "test.wait" } }), { { name = "seconds", type = "number" } }),
    leaf("w", "Worker", "h1"),
    sub,
  })
end

local function running()
  local c = fake.cluster{ config = { ["test.k"] = 2, ["test.wait"] = 5, ["test.other"] = 1 } }
  c:root(system())
  assert(c:configure())
  c:start()
  c:settle(1)
  return c
end

local function lines_with(c, text)
  local out = {}
  for _, l in ipairs(c.lines) do if l:find(text, 1, true) then out[#out + 1] = l end end
  for _, r in ipairs(c.reports) do
    if r.type == "log" and r.line:find(text, 1, true) then out[#out + 1] = r.line end
  end
  table.sort(out)  -- (each supervisor watches on its own: their order is not the point)
  return out
end

local function set_params(c)
  local out = {}
  for _, cmd in ipairs(c.commands) do if cmd:find("set_param", 1, true) then out[#out + 1] = cmd end end
  table.sort(out)
  return out
end

suite:case("a_change_reaches_every_leaf_whose_live_parameter_reads_the_key", function()
  local c = running()
  T.eq(c:node("main.g").args, { 2 }, "read at the start")
  c:config_set({ ["test.k"] = 3.5 })
  c:settle(2)
  T.eq(c:node("main.g").params, { k = 3.5 })
  T.eq(c:node("main.sub.g2").params, { k = 3.5 }, "a leaf of a sub-group: its own supervisor's watch")
  T.eq(lines_with(c, "main.g: k ="), { "main.g: k = 3.5 (live)" })
  T.eq(lines_with(c, "main.sub.g2: k ="), { "main.sub.g2: k = 3.5 (live)" })
  T.eq(set_params(c), { "main.g set_param", "main.sub.g2 set_param" })
  T.eq(c.root_sup.children.g.state, "running")
end)

suite:case("a_parameter_not_live_is_said_to_apply_at_the_next_start", function()
  local c = running()
  c:config_set({ ["test.wait"] = 9 })
  c:config_set({ ["test.other"] = 4 })  -- read by no leaf: nothing
  c:settle(2)
  T.eq(lines_with(c, "main.t: seconds"), { "main.t: seconds = 9 in the repository (config key 'test.wait'); not live: "
    .. "applies at the leaf's next start (restart)" })
  T.eq(set_params(c), {})
  T.eq(c.root_sup.children.t.state, "running")
end)

suite:case("a_refused_value_is_said_with_the_reason_and_the_leaf_runs_on", function()
  local c = running()
  c.refuse_param["main.g"] = "Gain main.g: parameter 'k' must be a number, got 'fast'"
  c.refuse_param["main.sub.g2"] = "Gain main.sub.g2: parameter 'k' not changed: the hook said no"
  c:config_set({ ["test.k"] = "fast" })
  c:settle(2)
  T.eq(lines_with(c, "not changed"), { "main.g: k not changed: parameter 'k' must be a number, got 'fast'",
                                       "main.sub.g2: k not changed: the hook said no" })
  T.eq(c.root_sup.children.g.state, "running")
  T.eq(c:node("main.g").params, nil)
  -- a table is no parameter: said, nothing sent
  c.refuse_param = {}
  c:config_set({ ["test.k"] = { 1, 2 } })
  c:settle(3)
  T.eq(#lines_with(c, "is a table; a controller parameter is a number, a string or a boolean"), 2)
  T.eq(#set_params(c), 2, "only the two refused before")
end)

suite:case("the_shutdown_ends_the_watches", function()
  local c = running()
  local stopped
  c.root_sup:shutdown(function() stopped = true end)
  c:settle(nil, function() return stopped end)
  T.eq(#c.config_watches, 0)
  c:config_set({ ["test.k"] = 7 })
  c:settle()
  T.eq(set_params(c), {})
end)

-- dca.clients.config: a supervisor's watch (tagged with its owner) and a console's of the same prefix on one
-- client: unwatching one leaves the other, and the daemon is asked to stop only when neither is left.
suite:case("a_console_unwatch_leaves_the_supervisors_watch_of_the_same_key", function()
  local sent = {}
  local c = require("dca.clients.config").over_channel({ request = function(_, msg, _, k)
    sent[#sent + 1] = msg.type .. " " .. msg.prefix
    k({ prefix = msg.prefix })
  end }, 1)
  local seen = {}
  c:watch("test.k", function(ev) seen[#seen + 1] = "sup " .. ev.value end, nil, "main")
  c:watch("test.k", function(ev) seen[#seen + 1] = "console " .. ev.value end)
  c:event({ type = "config_changed", key = "test.k", value = 1, prefix = "test.k" })
  c:unwatch("test.k")
  c:event({ type = "config_changed", key = "test.k", value = 2, prefix = "test.k" })
  c:unwatch("test.k", nil, "main")
  c:event({ type = "config_changed", key = "test.k", value = 3, prefix = "test.k" })
  T.eq(seen, { "sup 1", "console 1", "sup 2" })
  T.eq(sent, { "config_watch test.k", "config_watch test.k", "config_watch test.k", "config_unwatch test.k" })
end)

return suite:run(...)
