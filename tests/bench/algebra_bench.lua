-- Events per second through dca.algebra (BENCHMARKS.md): the paper's door expression and a generated
-- 1,000-leaf expression, each beside two baselines of the same iteration count, alternated A B A B: an empty
-- Lua loop, and the raw call (the same driver loop with the same events, each handed to a Lua function that
-- does nothing: what one event costs before the engine does anything). Per-event times come from batches of
-- BATCH events (os.clock has microsecond resolution).
--   dca lua tests/bench/algebra_bench.lua [events]
--   DCA_BENCH_BEFORE=FILE: also FILE, another version of lua/dca/algebra.lua (e.g. `git show
--   main:lua/dca/algebra.lua > /tmp/algebra_before.lua`), after each measurement of this one (variants suffixed
--   _before), so that a change is measured before and after in one run
-- Then the VM instructions an event costs (a count hook: independent of the machine's load; the driver's own
-- included, as in the raw call), for each expression and version measured.
--   DCA_BENCH_PROFILE=N: also where they go, on stderr: the N source lines of the door run with the most
--   instructions (a Lua 5.4 count hook every instruction: LuaJIT is not there to profile with).
local algebra = require "dca.algebra"
local before_file = os.getenv("DCA_BENCH_BEFORE")
local before = before_file and assert(loadfile(before_file))()

local N = tonumber((...)) or 400000
local BATCH = 100
local clock = os.clock

local function result(bench, variant, times, extra)
  table.sort(times)
  local function pct(p) return times[math.max(1, math.ceil(#times * p))] end
  local total = 0
  for _, t in ipairs(times) do total = total + t end
  local per = total / (#times * BATCH)
  io.write(string.format("RESULT bench=%s variant=%s n=%d p50_us=%.3f p99_us=%.3f p999_us=%.3f max_us=%.3f " ..
                         "events_per_s=%.0f batch=%d%s\n", bench, variant, #times * BATCH, pct(0.5) * 1e6 / BATCH,
                         pct(0.99) * 1e6 / BATCH, pct(0.999) * 1e6 / BATCH, times[#times] * 1e6 / BATCH,
                         1 / per, BATCH, extra or ""))
  io.flush()
end

-- The baseline: the same number of iterations of an empty loop, in batches.
local function empty_loop(n)
  local times = {}
  local x = 0
  for _ = 1, n // BATCH do
    local t0 = clock()
    for i = 1, BATCH do x = x + i end
    times[#times + 1] = clock() - t0
  end
  return times
end

-- A driver: `next_event()` returns name, kind, value of the next event; the run restarts when it ends.
-- `event` (default run.event) takes each event.
local function measure(run, next_event, n, event)
  local times = {}
  event = event or run.event
  run:start()
  for _ = 1, n // BATCH do
    local t0 = clock()
    for _ = 1, BATCH do
      local name, kind, v = next_event()
      event(run, name, kind, v)
      if run.st ~= "running" then run:start() end
    end
    times[#times + 1] = clock() - t0
  end
  return times
end

-------------------------------------------------------------------------------- door
local DOOR = "MotionControl , ((VisualServoing[lbl1] # DistDetector); ((OpenGripper, Approach[lbl1]) # HitDetector); " ..
             "CloseGripper ; PressHandle[lbl1] ; DoorOpen[lbl1])"
local function door_setup(engine)
  local noop = function() end
  local run = assert((engine or algebra).new(DOOR, { start = noop, abort = noop, activate = noop, deactivate = noop }))
  local script = { "DistDetector", "OpenGripper", "HitDetector", "CloseGripper", "PressHandle", "DoorOpen",
                   "MotionControl" }
  local i = 0
  local function next_event()
    i = i % #script + 1
    return script[i], "done", i
  end
  return run, next_event
end

-------------------------------------------------------------------------------- 1,000 leaves
math.randomseed(1000)
local function gen(first, count, rnd)
  if count == 1 then
    local name = "L" .. first
    if rnd(5) == 1 then name = name .. "[lbl1]" end
    return name, false
  end
  local parts = math.min(count, 2 + rnd(3))
  local ops = { ",", ";", "#", ":" }
  local op = ops[rnd(#ops)]
  if op == ":" then parts = 2 end
  local size, out = count // parts, {}
  local at = first
  for p = 1, parts do
    local c = (p == parts) and (first + count - at) or size
    local s, composite = gen(at, c, rnd)
    out[p] = composite and ("(" .. s .. ")") or s
    at = at + c
  end
  return table.concat(out, " " .. op .. " "), true
end
local BIG = (gen(1, 1000, math.random))

local function big_setup(engine)
  -- the driver answers each started leaf with DONE, in start order (a FIFO of started names)
  local running, queue, head, tail = {}, {}, 1, 0
  local run = assert((engine or algebra).new(BIG, {
    start = function(n) running[n] = true; tail = tail + 1; queue[tail] = n end,
    abort = function(n) running[n] = nil end,
  }))
  local function next_event()
    while true do
      if head > tail then error("algebra_bench: no leaf running in the 1,000-leaf expression") end
      local n = queue[head]
      queue[head] = nil
      head = head + 1
      if running[n] then
        running[n] = nil
        return n, "done", nil
      end
    end
  end
  return run, next_event
end

io.stderr:write(string.format("algebra_bench: %d events per measurement, door expression and a 1,000-leaf expression (%d chars)\n",
                              N, #BIG))
-- The raw-call baseline: the door's driver and events, each given to a function that does nothing.
local function raw_call(n)
  local run, nx = door_setup()
  return measure(run, nx, n, function() end)
end

for round = 1, 2 do
  result("lua_empty_loop", "n" .. N, empty_loop(N))
  result("lua_raw_call", "door_events", raw_call(N), " round=" .. round)
  local run, nx = door_setup()
  result("algebra_events", "door", measure(run, nx, N), " round=" .. round)
  if before then
    run, nx = door_setup(before)
    result("algebra_events", "door_before", measure(run, nx, N), " round=" .. round)
  end
  result("lua_empty_loop", "n" .. N, empty_loop(N))
  run, nx = big_setup()
  result("algebra_events", "generated_1000_leaves", measure(run, nx, N), " round=" .. round)
  if before then
    run, nx = big_setup(before)
    result("algebra_events", "generated_1000_leaves_before", measure(run, nx, N), " round=" .. round)
  end
end

-- VM instructions an event (and, with `lines`, per source line) over n events of a driver.
local function instructions(run, next_event, n, lines)
  local count, where, getinfo = 0, {}, debug.getinfo
  run:start()
  debug.sethook(function()
    count = count + 1
    if lines then
      local info = getinfo(2, "Sl")
      local k = info.short_src .. ":" .. (info.currentline or 0)
      where[k] = (where[k] or 0) + 1
    end
  end, "", 1)
  for _ = 1, n do
    local name, kind, v = next_event()
    run:event(name, kind, v)
    if run.st ~= "running" then run:start() end
  end
  debug.sethook()
  return count / n, where
end

local profile = tonumber(os.getenv("DCA_BENCH_PROFILE"))
for _, v in ipairs({ { "door", door_setup }, { "generated_1000_leaves", big_setup } }) do
  for _, engine in ipairs({ algebra, before }) do
    local run, nx = v[2](engine)
    local per, where = instructions(run, nx, 7000, profile and engine == algebra and v[1] == "door")
    io.write(string.format("RESULT bench=algebra_vm_instructions variant=%s%s per_event=%.1f\n", v[1],
                           engine == algebra and "" or "_before", per))
    if profile and next(where) then
      local rows, total = {}, 0
      for k, c in pairs(where) do rows[#rows + 1] = { k, c }; total = total + c end
      table.sort(rows, function(a, b) return a[2] > b[2] end)
      for i = 1, math.min(profile, #rows) do
        io.stderr:write(string.format("%5.1f%% %s\n", rows[i][2] * 100 / total, rows[i][1]))
      end
    end
  end
end
