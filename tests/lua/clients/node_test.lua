-- dca.clients.node against real processes: three `dca daemon`s on loopback acting as three hosts (A, B, C on
-- 127.0.0.1, .2, .3), nodes spawned from A's side on B and C, data flowing B -> C directly.
local T, core = require "dca.testing", require "dca.core"
local daemon_client, node_client = require "dca.clients.daemon", require "dca.clients.node"
local DCA = os.getenv("DCA_EXE") or "dca"
local suite, loop = T.suite("node"), core.loop()

-- Runs the loop until pred() (bounded: 10 s unless said), failing the case when it never holds.
local function wait(pred, what, seconds)
  T.ok(loop:run_until(pred, seconds or 10), "timed out waiting for " .. what)
end

-- A `dca daemon` started with io.popen; returns its address, pid.
local function start_daemon(host, ip, key_file, peers)
  local extra = ""
  for _, p in ipairs(peers or {}) do extra = extra .. " --peer " .. p end
  local cmd = string.format("%s daemon --host %s --listen %s:0 --key %s --grace 200%s & echo $!", DCA, host, ip,
    key_file, extra)
  local p = assert(io.popen(cmd, "r"))
  -- Two lines in either order: the shell's `echo $!` and the daemon's "listening on ADDR".
  local l1, l2 = p:read("l") or "", p:read("l") or ""
  local pid, line = l1, l2
  if l1:match("listening on") then pid, line = l2, l1 end
  local addr = line:match("listening on (%S+)")
  T.ok(addr, "daemon said: " .. line)
  return { addr = addr, pid = tonumber(pid), pipe = p, host = host }
end

local function stop_daemon(d)
  if d.stopped then return end
  d.stopped = true
  os.execute("kill " .. d.pid .. " 2>/dev/null")
  d.pipe:close()
end

local function alive(pid) return os.execute("kill -0 " .. pid .. " 2>/dev/null") == true end

-- Bytes a process has read (any file or socket): /proc/PID/io rchar.
local function rchar(pid)
  local f = io.open("/proc/" .. pid .. "/io", "r")
  if not f then return nil end
  local text = f:read("a")
  f:close()
  return tonumber(text:match("rchar:%s*(%d+)"))
end

-- Calls fn(cb) and waits for cb(reply, err); returns reply, err.
local function call(what, fn)
  local done, reply, err = false, nil, nil
  fn(function(r, e) done, reply, err = true, r, e end)
  wait(function() return done end, what)
  return reply, err
end

suite:case("three_hosts_nodes_on_b_and_c_data_direct_set_switch_pull_and_segv", function()
  local key_file = T.tmpname(".key")  -- the first daemon creates it (0600)
  local C = start_daemon("C", "127.0.0.3", key_file)
  local B = start_daemon("B", "127.0.0.2", key_file, { C.addr })
  local A = start_daemon("A", "127.0.0.1", key_file, { B.addr, C.addr })
  local daemons = { A, B, C }
  local ok, err = pcall(function()
    local opts = { key_file = key_file }
    local db = assert(call("daemon B", function(k) daemon_client.connect(B.addr, opts, k) end))
    local dc = assert(call("daemon C", function(k) daemon_client.connect(C.addr, opts, k) end))
    local da = assert(call("daemon A", function(k) daemon_client.connect(A.addr, opts, k) end))
    -- Spawn from A's side: a Counter on B, a Crash (a sink that dies at its 5th tick once run) on C.
    local exit_c
    local sb = assert(call("spawn on B", function(k)
      db:spawn({ "dca", "node", "--type", "Counter", "--name", "/sys/b", "--daemon", B.addr, "--key", key_file, "--",
                 "0.001" }, { name = "/sys/b" }, k)
    end))
    local sc = assert(call("spawn on C", function(k)
      dc:spawn({ "dca", "node", "--type", "Crash", "--name", "/sys/c", "--daemon", C.addr, "--key", key_file, "--",
                 "5", "segv", "0.001" }, { name = "/sys/c", on_exit = function(ev) exit_c = ev end }, k)
    end))
    -- Both are found through A's daemon (its peers answer).
    local lb = assert(call("lookup /sys/b", function(k) da:lookup("/sys/b", { wait_ms = 5000 }, k) end))
    local lc = assert(call("lookup /sys/c", function(k) da:lookup("/sys/c", { wait_ms = 5000 }, k) end))
    T.eq(lb.host, "B")
    T.eq(lc.host, "C")
    T.eq(lb.endpoints.pid, sb.pid)
    local nb = assert(call("control of /sys/b", function(k) node_client.connect(lb.endpoints.control, opts, k) end))
    local nc = assert(call("control of /sys/c", function(k) node_client.connect(lc.endpoints.control, opts, k) end))
    local b_events = {}
    nb:on_event(function(msg) b_events[#b_events + 1] = msg end)

    -- B's output straight to C's input: TCP, since they are different hosts.
    local r = assert(call("connect", function(k)
      nb:connect({ out = "Count", to = "/sys/c", ["in"] = "In", set = "sys:x[push]" }, k)
    end))
    T.eq(r.transport, "tcp")
    local e
    r, e = call("bad connect", function(k) nb:connect({ out = "Count", to = "/sys/c", ["in"] = "Inn", set = "s" }, k) end)
    T.eq(r, nil)
    T.eq(e, "no input 'Inn' on /sys/c; inputs are: In")

    local a_before = rchar(A.pid)
    T.ok(a_before, "reads /proc/" .. A.pid .. "/io")
    assert(call("run b", function(k) nb:run(nil, k) end))
    -- Inactive: nothing arrives.
    local function count_at_c()
      local rr = assert(call("read c", function(k) nc:read("In", k) end))
      return rr.count, rr.value
    end
    local function skipped_at_b()
      local p = assert(call("ports b", function(k) nb:ports(k) end))
      return p.links[1].skipped
    end
    local s0 = skipped_at_b()
    wait(function() return skipped_at_b() >= s0 + 10 end, "B's samples skipped while inactive")
    T.eq((count_at_c()), 0)
    -- Active: samples flow.
    assert(call("activate", function(k) nb:activate("sys:x[push]", k) end))
    wait(function() return count_at_c() >= 50 end, "50 samples at C")
    local n, v = count_at_c()
    T.ok(type(v) == "number" and v >= 1, "C reads a count")
    -- Off: they stop (after any already in flight); on: they resume. Same socket throughout.
    assert(call("deactivate", function(k) nb:deactivate("sys:x[push]", k) end))
    local s1 = skipped_at_b()
    wait(function() return skipped_at_b() >= s1 + 20 end, "B's samples skipped after deactivate")
    local frozen = count_at_c()
    s1 = skipped_at_b()
    wait(function() return skipped_at_b() >= s1 + 20 end, "more skipped")
    T.eq((count_at_c()), frozen, "no samples while the set is inactive")
    assert(call("activate again", function(k) nb:activate("sys:x[push]", k) end))
    wait(function() return count_at_c() > frozen + 200 end, "samples resume")
    local pc = assert(call("ports c", function(k) nc:ports(k) end))
    T.eq(pc.accepted, 1, "one data socket at C, never reopened")
    local received = count_at_c()
    T.ok(pc.bytes_received >= received * 13, "C received the samples' frames (13 bytes each)")

    -- No sample went through A: its daemon read (almost) nothing while they flowed.
    local a_after = rchar(A.pid)
    io.stderr:write(string.format("A's daemon read %d bytes while C received %d bytes (%d samples)\n",
      a_after - a_before, pc.bytes_received, received))
    T.ok(a_after - a_before < pc.bytes_received / 4,
      string.format("A's daemon read %d bytes while C received %d", a_after - a_before, pc.bytes_received))

    -- Pull: C asks, B answers with its latest sample.
    assert(call("deactivate push", function(k) nb:deactivate("sys:x[push]", k) end))
    r = assert(call("connect pull", function(k)
      nb:connect({ out = "Count", to = "/sys/c", ["in"] = "In", set = "sys:x[pull]", mode = "pull" }, k)
    end))
    assert(call("activate pull", function(k) nb:activate("sys:x[pull]", k) end))
    local before_pull = count_at_c()
    local pulled = assert(call("pull", function(k) nc:pull("In", 5, k) end))
    T.eq(pulled.count, before_pull + 1)
    T.ok(pulled.value > 1, "the pulled value is B's latest count")

    -- Kill the node on C with SIGSEGV (Crash at its 5th tick): the signal is an event here, and B's data
    -- connection reports itself broken.
    assert(call("run c", function(k) nc:run(nil, k) end))
    wait(function() return exit_c ~= nil end, "C's exit event")
    T.eq(exit_c.signal, "SIGSEGV")
    T.eq(exit_c.name, "/sys/c")
    T.eq(exit_c.pid, sc.pid)
    wait(function()
      for _, ev in ipairs(b_events) do if ev.type == "broken" then return true end end
    end, "broken event from B")

    -- Stopping B's daemon leaves no child behind.
    T.ok(alive(sb.pid), "/sys/b runs")
    stop_daemon(B)
    wait(function() return not alive(sb.pid) end, "/sys/b gone with its daemon")
  end)
  for _, d in ipairs(daemons) do stop_daemon(d) end
  os.remove(key_file)
  if not ok then error(err, 0) end
end)

suite:case("init_failure_and_done_value_through_the_client", function()
  local key_file = T.tmpname(".key")
  local D = start_daemon("H", "127.0.0.1", key_file)
  local ok, err = pcall(function()
    local opts = { key_file = key_file }
    local d = assert(call("daemon", function(k) daemon_client.connect(D.addr, opts, k) end))
    local bad
    assert(call("spawn bad", function(k)
      d:spawn({ "dca", "node", "--type", "Timer", "--name", "/t/bad", "--daemon", D.addr, "--key", key_file, "--",
                "soon" }, { on_exit = function(ev) bad = ev end }, k)
    end))
    wait(function() return bad ~= nil end, "the misconfigured node exits")
    T.eq(bad.code, 1)
    assert(call("spawn timer", function(k)
      d:spawn({ "dca", "node", "--type", "Timer", "--name", "/t/timeout", "--daemon", D.addr, "--key", key_file, "--",
                "0.05" }, {}, k)
    end))
    local l = assert(call("lookup", function(k) d:lookup("/t/timeout", { wait_ms = 5000 }, k) end))
    local n = assert(call("control", function(k) node_client.connect(l.endpoints.control, opts, k) end))
    local value
    n:on_done(function(v) value = v end)
    assert(call("init", function(k) n:init(k) end))
    assert(call("run", function(k) n:run(nil, k) end))
    wait(function() return value ~= nil end, "Timer's DONE")
    T.eq(value, "timeout")
    local st = assert(call("stats", function(k) n:stats(k) end))
    T.eq(st.clock, "wall")
    T.eq(st.timers[1].count, 1)
    local _, e = call("unknown", function(k) n:request({ type = "nope" }, nil, k) end)
    T.eq(e, "unknown request 'nope' for node /t/timeout")
    local closed
    n:on_close(function(why) closed = why end)
    assert(call("exit", function(k) n:exit(k) end))
    wait(function() return closed ~= nil end, "node exits")
  end)
  stop_daemon(D)
  os.remove(key_file)
  if not ok then error(err, 0) end
end)

return suite:run(...)
