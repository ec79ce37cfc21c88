-- `dca run --record FILE.mcap` on the wall clock (dca.launch.wall_record, docs/recording.md "Recording a
-- wall-clock run"): a run against a driver, or on daemons without a simulator, writes its own recording: its lines
-- on /dca/events and, per leaf on a real-time thread, its figures there on /dca/rt/<path>, every second and at the
-- end. And a host's shared node (--placement host) runs each leaf of an rt { } group on the real-time thread of
-- its group's setting, one thread per distinct setting (host/node.h, `add {rt}`). The figures are only checked
-- for what any run gives (counts, order, consistency), never for timing. The same recording read by @mcap/core:
-- mcap.wall_clock_rt_mcap_core (tests/mcap/roundtrip.sh wall).
local T = require "dca.testing"
local core = require "dca.core"
local suite = T.suite("rt_record")

-- A group `loop` on a real-time thread with a Counter of 150 ticks at 100 Hz, beside a group `plain` on none.
local LOOP = T.src .. "/tests/lua/launch/systems/rt_loop.dca"

-- Runs `dca run SYSTEM ARGS --record F.mcap` (bounded); it must end DONE. --> the recording (core.mcap_read),
-- the run's output
local function recorded_run(system, args)
  local file = T.tmpname(".mcap")
  local out, rc = T.sh("timeout 120 " .. T.exe .. " run " .. system .. " " .. args .. " --record " .. file)
  T.kept_logs(out)
  T.eq(rc, 0, "the run ends DONE:\n" .. out)
  T.contains(out, "recorded " .. file .. ": ")
  local rec, err = core.mcap_read(file)
  T.ok(rec, "the recording reads: " .. tostring(err))
  return rec, out
end

-- The messages of `topic`, decoded, in file order: { {t = ns, v = table}, ... } (nil when no such channel).
local function messages(rec, topic)
  local id
  for cid, ch in pairs(rec.channels) do if ch.topic == topic then id = cid end end
  if not id then return nil end
  local out = {}
  for _, m in ipairs(rec.messages) do
    if m.channel == id then out[#out + 1] = { t = m.t, v = assert(core.json_decode(m.data)) } end
  end
  return out
end

-- A /dca/rt/<path> message's figures are whole and consistent: the histograms' buckets add up to their n, the
-- quantiles ordered, every count a count. While the leaf runs, its totals may be one record apart (read without
-- a lock: host/rt/histogram.h); `final`: at the end, exact.
local function check_figures(f, what, final)
  local slack = final and 0 or 1
  for _, k in ipairs({ "runs", "overruns", "missed", "dropped", "thread" }) do
    T.ok(math.type(f[k]) == "integer" and f[k] >= 0, what .. ": " .. k .. " = " .. tostring(f[k]))
  end
  for _, k in ipairs({ "allocations", "locks", "page_faults" }) do
    T.ok(math.type(f.contract[k]) == "integer", what .. ": contract." .. k)
  end
  for _, h in ipairs({ "wake", "exec" }) do
    local x, sum = f[h], 0
    for _, b in ipairs(x.buckets) do
      T.ok(b[1] > 0 and math.type(b[2]) == "integer" and b[2] > 0, what .. ": a bucket of " .. h)
      sum = sum + b[2]
    end
    T.ok(math.abs(sum - x.n) <= slack, what .. ": the buckets of " .. h .. " add up to its n")
    T.ok(x.p50_us <= x.p99_us and x.p99_us <= x.p999_us and x.p999_us <= x.max_us, what .. ": " .. h .. " quantiles")
  end
  T.ok(math.abs(f.wake.n - f.runs) <= slack, what .. ": one wake-up per run")
end

suite:case("a_driver_run_records_its_lines_and_each_rt_leafs_figures_on_the_wall_clock", function()
  local before = os.time()
  local rec, out = recorded_run(LOOP, "--driver 'Gain(\"h1\", 2)'")
  local after = os.time() + 1
  -- the real-time leaf's figures: some while it ran (1 Hz), the last at the end; runs never go back
  local figs = messages(rec, "/dca/rt/main/loop/n")
  T.ok(figs and #figs >= 1, "the channel /dca/rt/main/loop/n")
  local last_runs, last_t = 0, 0
  for i, m in ipairs(figs) do
    check_figures(m.v, "message " .. i, i == #figs)
    T.eq(m.v.path, "main.loop.n")
    T.ok(m.v.runs >= last_runs, "runs never go back")
    T.ok(m.t >= last_t and m.t >= before * 1e9 and m.t <= after * 1e9, "log time on the wall clock, in order")
    last_runs, last_t = m.v.runs, m.t
  end
  T.eq(figs[#figs].v.runs, 150, "the last figures are the end's: every tick ran")
  T.ok(figs[#figs].v.thread > 0, "a thread of its own")
  T.eq(messages(rec, "/dca/rt/main/plain/n"), nil, "no figures of a leaf without rt { }")
  -- every line the run printed is on /dca/events, in order
  local events = messages(rec, "/dca/events")
  local i = 1
  for line in out:gmatch("[^\n]+") do
    local text = line:match("^%[%s*[%d.]+%] (.*)$")
    if text then
      while events[i] and events[i].v.line ~= text do i = i + 1 end
      T.ok(events[i], "the line on /dca/events: " .. text)
    end
  end
  local done
  for _, e in ipairs(events) do if e.v.path == "main.loop.n" and e.v.state == "done" then done = true end end
  T.ok(done, "the transition main.loop.n: done, with its path and state")
end)

-- --placement host: the leaves of groups a (rt { cpu 0; }) and b (rt { priority 80; cpu 0; }) and c (none) in
-- one shared node: a's two leaves on one real-time thread, b's on another, c's on none.
suite:case("a_hosts_shared_node_runs_each_rt_groups_leaves_on_the_thread_of_its_setting", function()
  local system = T.tmpfile([[
process A(h) {
  host { h }
  rt { cpu 0; }
  instantiated_processes { n instof Counter(h, 0.01, 100); m instof Counter(h, 0.01, 100); }
  internal_event_actions { n , m }
}
process B(h) {
  host { h }
  rt { priority 80; cpu 0; }
  instantiated_processes { n instof Counter(h, 0.01, 100); }
  internal_event_actions { n }
}
process C(h) {
  host { h }
  instantiated_processes { n instof Counter(h, 0.01, 100); }
  internal_event_actions { n }
}
process main() {
  instantiated_processes { a instof A("h1"); b instof B("h1"); c instof C("h1"); }
  internal_event_actions { a , b , c }
}
]])
  local rec = recorded_run(system, "--placement host")
  local function last(path)
    local figs = messages(rec, "/dca/rt/" .. path:gsub("%.", "/"))
    T.ok(figs and #figs > 0, "figures of " .. path .. " (on a real-time thread)")
    check_figures(figs[#figs].v, path, true)
    T.eq(figs[#figs].v.runs, 100, path .. ": every tick ran there")
    return figs[#figs].v.thread
  end
  local an, am, bn = last("main.a.n"), last("main.a.m"), last("main.b.n")
  T.ok(an > 0 and bn > 0, "real-time threads")
  T.eq(am, an, "the leaves of one setting share its thread")
  T.ok(bn ~= an, "another setting, another thread")
  T.eq(messages(rec, "/dca/rt/main/c/n"), nil, "the leaf without rt { } is on no real-time thread")
end)

return suite:run(...)
