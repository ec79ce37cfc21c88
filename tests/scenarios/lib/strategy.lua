-- The body of the strategy scenarios (tests/scenarios/strategy_<strategy>.lua, in memory and real): the group
-- `line` of scripts/systems/test_strategy.dca (src -> gain -> sink, and count, in that instantiation order) with
-- the given strategy. Its Gain is killed by SIGSEGV: the policy restarts the children the strategy names, the
-- running ones stopped in reverse start order, then all started again in order; the others keep their pids;
-- samples flow again both ways through the new processes (the new Gain reads its gain from the repository
-- again: 3); the algebra saw nothing and the task carries on to DONE. tree() shows the counts and the budget.
return function(strategy)
  local S = require "dca.scenario"
  local src = os.getenv("DCA_SOURCE_DIR") or "."
  local file = src .. "/scripts/systems/test_strategy.dca"
  local spec = S.spec(file)
  spec.children[1].spec.supervision.strategy = strategy
  local sys = S.system(file, { spec = spec })

  local ORDER = { "src", "gain", "sink", "count" }
  local RESTARTED = {   -- the children each strategy restarts after a crash of gain, in start order
    one_for_one = { "gain" }, one_for_all = ORDER, rest_for_one = { "gain", "sink", "count" },
  }
  local restarts = RESTARTED[strategy]
  local restarted = {}
  for _, n in ipairs(restarts) do restarted[n] = true end

  local function pid(name)
    local path = "main.line." .. name
    if sys.backend ~= "memory" then return sys:pid(path) end
    for _, p in ipairs(sys.c.procs) do if p.path == path and p.alive then return p.pid end end
  end

  -- the names in the lines after `from` that match "main.line.NAME: <what>", in order
  local function names(what, from)
    local out = {}
    for _, l in ipairs(sys:lines_matching("^main%.line%.%a+: " .. what, from)) do
      out[#out + 1] = l:match("^main%.line%.(%a+):")
    end
    return out
  end

  local before, from
  S.step("the line runs: src (1) -> gain (2, from the repository) -> sink", function()
    sys:up()
    sys:run()
    sys:wait_read("main.line.sink", "Out", function(v) return v == 2 end, 10)
    before = {}
    for _, n in ipairs(ORDER) do before[n] = pid(n) end
  end)

  S.step(strategy .. ": a SIGSEGV of gain restarts " .. table.concat(restarts, ", "), function()
    sys:config("h2"):set("test.gain", 3)
    from = #sys:transitions()
    sys:kill("main.line.gain", "SEGV")
    S.contains(sys:wait_restart("main.line.gain", 20, from), "main.line.gain: restarted 1/3 in 60 s")
    sys:wait_restart("main.line." .. restarts[#restarts], 20, from)
    for _, n in ipairs(ORDER) do
      if restarted[n] then S.ok(pid(n) and pid(n) ~= before[n], n .. " is a new process")
      else S.eq(pid(n), before[n], n .. " never stopped") end
    end
  end)

  S.step("the order: running children stopped in reverse start order, then all started in order", function()
    local stops = {}
    for i = #restarts, 1, -1 do if restarts[i] ~= "gain" then stops[#stops + 1] = restarts[i] end end
    S.eq(names("stopping to restart", from), stops, "stopped LIFO (gain had crashed)")
    S.eq(names("restarted", from), restarts, "started in instantiation order")
    S.eq(#sys:lines_matching("^main%.line: " .. strategy .. " after gain killed by SIGSEGV", from), 1)
  end)

  S.step("samples flow again both ways: src -> new gain (3, read again) -> sink", function()
    sys:wait_read("main.line.sink", "Out", function(v) return v == 3 end, 10)
    sys:wait_state("main.line.count", "running", 10)
  end)

  S.step("tree() shows the restart counts and the budget", function()
    local repl = require("dca.supervisor.console").new(sys.backend == "memory" and sys.c.root_sup or sys.sup)
    local out
    repl:eval("tree()", function(o) out = o end)
    sys:wait("the console's tree()", function() return out ~= nil end, 30)
    S.contains(out, "[" .. strategy .. ": 1/3 in 60 s used, 1 restarts]")
    S.ok(out:find("gain%s.-restarted 1"), "gain restarted once:\n" .. out)
  end)

  S.step("the algebra saw nothing: the task carries on to DONE", function()
    S.eq(sys.outcome, nil)
    sys:inject("main.line.count", "done", 5)
    local out = sys:wait_outcome(20)
    S.eq(out.type, "done")
    S.eq(out.value, 5)
  end)
  return S.finish()
end
