-- dca.algebra beyond the shared cases: error positions, the lexical rules, bindings, recurrence at scale,
-- re-entrant events, rendering and the log.
local T = require "dca.testing"
local algebra = require "dca.algebra"
local suite = T.suite("algebra")

-- A run whose commands are recorded as text lines in `log`.
local function recorder(expr_text, running_before)
  local log, inits = {}, {}
  local before = {}
  for _, n in ipairs(running_before or {}) do before[n] = true end
  local run = assert(algebra.new(expr_text, {
    start = function(n, init) log[#log + 1] = "start " .. n; inits[#inits + 1] = { n, init } end,
    abort = function(n) log[#log + 1] = "abort " .. n end,
    activate = function(n, l) log[#log + 1] = "+" .. n .. "[" .. l .. "]" end,
    deactivate = function(n, l) log[#log + 1] = "-" .. n .. "[" .. l .. "]" end,
    is_running = function(n) return before[n] == true end,
  }))
  return run, log, inits
end

local function parse_error(text)
  local e, err, info = algebra.parse(text)
  T.ok(e == nil, "expected a parse error for " .. T.show(text))
  T.ok(type(err) == "string" and type(info) == "table", "err and info")
  return err, info
end

suite:case("errors_give_the_column", function()
  local cases = {
    { "A && B", "column 3: unknown operator '&&'" },
    { "A ; B)", "column 6: unbalanced parentheses" },
    { "(A ; B", "column 1: unbalanced parentheses" },
    { "A ;", "column 3: trailing operator ';'" },
    { "A B", "column 3: missing operator" },
    { "A ; ()", "column 5: empty parentheses" },
    { "A[]", "column 2: empty label" },
    { "A[l", "column 2: unterminated label" },
    { "(A)[l]", "column 4: label must follow a process name" },
    { "A [l]", "column 3: label must follow a process name" },
    { "A ; 2B", "column 5: invalid process name '2B'" },
    { "A , (B ; A)", "column 10: process 'A' may run concurrently with itself" },
    { "A[l1] , A[l2]", "column 9: process 'A' may run concurrently with itself" },
    { "A : ; B", "column 5: missing operand" },
    { "A :: B", "column 4: missing operand" },
    { "P^v : Q_v", "column 2: unknown operator '^'" },
    { "A ]", "column 3: unexpected ']'" },
    { "A[2x]", "column 3: invalid label name '2x'" },
    { "A , ( ; B)", "column 7: missing operand" },
  }
  for _, c in ipairs(cases) do
    local err = parse_error(c[1])
    T.contains(err, c[2], c[1])
  end
end)

suite:case("multi_line_errors_give_line_and_column", function()
  local err, info = parse_error("A ,\n  (B ;\n   C &)")
  T.contains(err, "line 3, column 6: unknown operator '&'")
  T.eq({ info.line, info.col, info.pos }, { 3, 6, 17 })
  T.eq(info.msg, "unknown operator '&'")
end)

suite:case("parse_never_raises_on_odd_input", function()
  for _, s in ipairs({ "\0", "A\0B", "((((", "))))", "[", "]", "A[", "A[ ", "A[l ]", "\255\254", ":;", ";:", "A:;",
                       "A :; B :; C", string.rep("(", 5000) .. "A" .. string.rep(")", 5000), 42 }) do
    local ok, e = pcall(algebra.parse, s)
    T.ok(ok, "raised on " .. T.show(s) .. ": " .. tostring(e))
  end
  local e, err = algebra.parse(string.rep("(", 5000) .. "A" .. string.rep(")", 5000))
  T.ok(not e)
  T.contains(err, "nested too deeply")
  T.ok(algebra.parse(string.rep("(", 900) .. "A" .. string.rep(")", 900)), "900 levels are fine")
end)

suite:case("whitespace_inside_labels_and_rec_token", function()
  local e = assert(algebra.parse("A[ l1 ] :;B"))
  T.eq(e.root.op, ":;")
  T.eq(e.root.kids[1].label, "l1")
  T.eq(e.names, { "A", "B" })
end)

suite:case("tree_shapes_follow_precedence", function()
  local function shape(text) return algebra.tostring(assert(algebra.parse(text))) end
  T.eq(shape("A ; B , C"), "A ; B, C")
  T.eq(shape("(A , B) , C"), "(A, B), C")
  T.eq(shape("A , (B , C)"), "A, (B, C)")
  T.eq(shape("A : B : C"), "A : B : C")
  T.eq(shape("A : (B : C)"), "A : (B : C)")
  T.eq(shape("P : Q :; R"), "P : Q :; R")
  T.eq(shape("hit # forcedata , compliant"), "hit # forcedata, compliant")
  T.eq(shape("hit # (forcedata[lbl1], compliant[lbl1], puma)"), "hit # (forcedata[lbl1], compliant[lbl1], puma)")
  local e = assert(algebra.parse("A # B # C"))
  T.eq(#e.root.kids, 3, "an unparenthesised chain is one node")
  e = assert(algebra.parse("(A # B) # C"))
  T.eq(#e.root.kids, 2, "a parenthesised sub-chain stays nested")
end)

suite:case("nodes_carry_line_and_column", function()
  local e = assert(algebra.parse("A ,\n  B[l]"))
  T.eq({ e.leaves[2].name, e.leaves[2].label, e.leaves[2].line, e.leaves[2].col }, { "B", "l", 2, 3 })
end)

suite:case("binding_is_lexical", function()
  -- X : (P : Q): P gets X's value, Q gets P's; the left operand of ':' sees the outer binding.
  local run, _, inits = recorder("X : (P : Q)")
  run:start("outer")
  run:event("X", "done", "x")
  run:event("P", "done", "p")
  T.eq(inits, { { "X", "outer" }, { "P", "x" }, { "Q", "p" } })
end)

suite:case("rec_outer_binding_reaches_every_iteration", function()
  local run, _, inits = recorder("F : (P :; Q)")
  run:start()
  run:event("F", "done", "f")
  run:event("P", "done", 1)
  run:event("Q", "done", "ignored-value")
  run:event("P", "done", 2)
  T.eq(inits, { { "F" }, { "P", "f" }, { "Q", 1 }, { "P", "f" }, { "Q", 2 } })
end)

suite:case("recurrence_100000_iterations_without_stack_growth", function()
  local starts = 0
  local run = assert(algebra.new("Stop # (P :; Q)", { start = function() starts = starts + 1 end }))
  run:start()
  local depth0 = 0
  while debug.getinfo(depth0 + 1, "l") do depth0 = depth0 + 1 end
  local max_depth = 0
  local probe = algebra.new("Stop # (P :; Q)", { start = function()
    local d = 0
    while debug.getinfo(d + 1, "l") do d = d + 1 end
    if d > max_depth then max_depth = d end
  end })
  probe:start()
  for i = 1, 100000 do
    T.ok(run:event("P", "done", i), "P taken")
    T.ok(run:event("Q", "done"), "Q taken")
    if i % 10000 == 0 then
      probe:event("P", "done", i)
      probe:event("Q", "done")
    end
  end
  T.eq(starts, 1 + 1 + 2 * 100000)
  T.eq(run:status(), "running")
  T.ok(max_depth < depth0 + 20, "stack depth stays bounded: " .. max_depth)
  T.ok(run:event("Stop", "done", "s"))
  T.eq({ run:status() }, { "done", "s" })
  T.eq(run:running(), {})
end)

local DOOR = "MotionControl , ((VisualServoing[lbl1] # DistDetector); ((OpenGripper, Approach[lbl1]) # HitDetector); " ..
             "CloseGripper ; PressHandle[lbl1] ; DoorOpen[lbl1])"

suite:case("door_approach_crashes_aborts_everything_innermost_first", function()
  local run, log = recorder(DOOR)
  run:start()
  run:event("DistDetector", "done")
  T.ok(run:event("Approach", "error", "SIGSEGV"))
  T.eq(run:status(), "aborted")
  T.eq(log, { "start MotionControl", "+VisualServoing[lbl1]", "start VisualServoing", "start DistDetector",
              "abort VisualServoing", "-VisualServoing[lbl1]", "start OpenGripper", "+Approach[lbl1]",
              "start Approach", "start HitDetector", "-Approach[lbl1]", "abort OpenGripper", "abort HitDetector",
              "abort MotionControl" })
  T.eq(run:running(), {})
end)

local TIDY = "Timeout # (FindObjectA : PlaceA , FindObjectB : PlaceB , FindObjectC : PlaceC)"

suite:case("tidy_timeout_first_aborts_lifo", function()
  local run, log = recorder(TIDY)
  run:start()
  run:event("FindObjectB", "done", "posB")
  run:event("Timeout", "done", "timeout")
  T.eq({ run:status() }, { "done", "timeout" })
  T.eq(log, { "start Timeout", "start FindObjectA", "start FindObjectB", "start FindObjectC", "start PlaceB",
              "abort PlaceB", "abort FindObjectC", "abort FindObjectA" })
end)

suite:case("tidy_find_fails_aborts_the_task", function()
  local run, log = recorder(TIDY)
  run:start()
  run:event("FindObjectC", "done", "posC")
  run:event("FindObjectA", "aborted", "not found")
  T.eq(run:status(), "aborted")
  T.eq(log, { "start Timeout", "start FindObjectA", "start FindObjectB", "start FindObjectC", "start PlaceC",
              "abort PlaceC", "abort FindObjectB", "abort Timeout" })
end)

suite:case("deadline_that_aborts_ends_aborted", function()
  local run, log = recorder("Deadline # Task")
  run:start()
  run:event("Deadline", "aborted", "deadline")
  T.eq(run:status(), "aborted")
  T.eq(log, { "start Deadline", "start Task", "abort Task" })
end)

suite:case("abort_cascades_innermost_first", function()
  local run, log = recorder("T # (P , Q)")
  run:start()
  run:event("P", "aborted")
  T.eq(log, { "start T", "start P", "start Q", "abort Q", "abort T" })
  T.eq(run:status(), "aborted")
end)

suite:case("conflict_in_disabling_start_stops_starting", function()
  local run, log = recorder("A # X # B", { "X" })
  T.eq(run:start(), false)
  T.eq(log, { "start A", "abort A" })
  T.eq(run:status(), "aborted")
end)

suite:case("conflict_in_later_sequence_step_aborts_whole", function()
  local run, log = recorder("M , (A ; X)", { "X" })
  run:start()
  T.ok(run:event("A", "done"))
  T.eq(log, { "start M", "start A", "abort M" })
  T.eq(run:status(), "aborted")
end)

suite:case("conflict_on_a_later_iteration_aborts_the_recurrence", function()
  local taken_by_other = false
  local log = {}
  local run = assert(algebra.new("M # (P :; Q)", {
    start = function(n) log[#log + 1] = "start " .. n end,
    abort = function(n) log[#log + 1] = "abort " .. n end,
    is_running = function(n) return n == "P" and taken_by_other end,
  }))
  run:start()
  run:event("P", "done", 1)
  taken_by_other = true          -- someone else starts P while Q runs
  T.ok(run:event("Q", "done"))
  T.eq(log, { "start M", "start P", "start Q", "abort M" })
  T.eq(run:status(), "aborted")
  T.eq(run:log()[#run:log()], "abort M")
end)

suite:case("external_abort_after_finish_has_no_effect", function()
  local run, log = recorder("A ; B")
  run:start()
  run:event("A", "done")
  run:event("B", "done", 2)
  T.eq(run:abort(), false)
  T.eq({ run:status() }, { "done", 2 })
  T.eq(log, { "start A", "start B" })
  T.eq(run:event("B", "done"), false, "stale after the end")
end)

suite:case("values_pass_through_opaquely_even_false", function()
  local inits = {}
  local run = assert(algebra.new("A : B", { start = function(n, v) inits[#inits + 1] = { n, v } end }))
  run:start()
  run:event("A", "done", false)
  run:event("B", "done", false)
  T.eq({ run:status() }, { "done", false })
  T.eq(inits, { { "A" }, { "B", false } })
  local t = {}
  run:start()
  run:event("A", "done", t)
  run:event("B", "done", t)
  T.ok(select(2, run:status()) == t, "the same table, not a copy")
end)

suite:case("finished_run_can_start_again", function()
  local run, log = recorder("A , B")
  run:start()
  run:event("A", "done", 1)
  run:event("B", "done", 2)
  T.eq({ run:status() }, { "done", { n = 2, 1, 2 } })
  T.ok(run:start())
  run:event("B", "done", 3)
  run:event("A", "done")
  T.eq({ run:status() }, { "done", { n = 2, [2] = 3 } })
  T.eq(#log, 4)
  T.raises(function() run:start(); run:start() end)
end)

suite:case("reentrant_events_are_queued_run_to_completion", function()
  -- A start command that reports an event synchronously: it must be processed after the current one.
  local run
  local log = {}
  run = assert(algebra.new("A ; B ; C", {
    start = function(n)
      log[#log + 1] = "start " .. n
      if n == "B" then T.eq(run:event("B", "done", "b"), nil, "queued") end
    end,
  }))
  run:start()
  T.ok(run:event("A", "done"))
  T.eq(log, { "start A", "start B", "start C" })
  T.eq(run:running(), { "C" })
end)

suite:case("queued_events_drain_at_one_stack_depth", function()
  -- Each start reports its DONE at once (queued): 300 steps run one after the other, none inside another.
  local names = {}
  for i = 1, 300 do names[i] = "A" .. i end
  local run
  local depths = {}
  local function depth()
    local d = 1
    while debug.getinfo(d + 1, "l") do d = d + 1 end
    return d
  end
  run = assert(algebra.new(table.concat(names, " ; "), {
    start = function(n)
      depths[#depths + 1] = depth()
      run:event(n, "done", n)
    end,
  }))
  T.eq(run:start(), false, "the whole sequence ran within start()")
  T.eq({ run:status() }, { "done", "A300" })
  T.eq(#depths, 300)
  T.eq(depths[300], depths[2], "the 300th start at the depth of the 2nd")
end)

suite:case("snapshot_and_restore_give_back_values_bindings_and_the_start_order", function()
  local run, log = recorder("(P , Q , R[l]) ; S : T")
  run:start("x")
  run:event("P", "done", 1)
  local s = run:snapshot()
  T.eq(s.running, { 4, 5 })  -- Q, R in start order (node ids: 1 the ;, 2 the , 3 P)
  T.eq(s.cnt[2], 2)
  T.eq(s.vals[2], { n = 3, 1 })
  local function finish()
    run:event("R", "done", 3)
    run:event("Q", "done", 2)
    run:event("S", "done", "s")
    return { run:status() }, run:running()
  end
  T.eq({ finish() }, { { "running" }, { "T" } })
  local first = #log
  for _ = 1, 2 do  -- the snapshot stays usable
    run:restore(s)
    T.eq(run:running(), { "Q", "R[l]" })
    T.ok(run:is_running("R") and not run:is_running("T") and not run:is_running("P"))
    T.eq(run:render(), "(P , *Q* , *R[l]*) ; S : T")
    T.eq({ finish() }, { { "running" }, { "T" } })
  end
  T.eq(log[first], "start T")
  T.eq(log[#log], "start T")
  run:event("T", "done", "t")
  T.eq({ run:status() }, { "done", "t" })
  T.eq(s.vals[2], { n = 3, 1 }, "the snapshot's values are a copy")
end)

suite:case("the_log_renders_every_kind_of_entry", function()
  local run = assert(algebra.new("A[l] , B , C", { is_running = function(n) return n == "C" end }))
  T.eq(run:start(5), false)
  run:event("A", "error", "crash")
  local other = assert(algebra.new("D : E"))
  other:start()
  other:event("D", "aborted", "why")
  other:event("D", "done")
  other:start()
  other:abort()
  T.eq(run:log(), { "+A[l]", "start A[l] init=5", "start B init=5", "conflict C (already running)", "abort B",
                    "abort A", "-A[l]", "ignored A error" })
  T.eq(other:log(), { "start D", "event D aborted", "ignored D done", "start D", "abort (external)",
                      "abort D" })
end)

suite:case("unknown_event_kind_is_a_programming_error", function()
  local run = assert(algebra.new("A"))
  run:start()
  T.contains(T.raises(function() run:event("A", "finished") end), "unknown event kind")
end)

suite:case("render_marks_running_leaves", function()
  local run = assert(algebra.new("MotionControl , (VisualServoing[lbl1] # DistDetector) ; CloseGripper"))
  run:start()
  T.eq(run:render(), "*MotionControl* , (*VisualServoing[lbl1]* # *DistDetector*) ; CloseGripper")
  run:event("DistDetector", "done")
  T.eq(run:render(function(s) return "<" .. s .. ">" end),
       "<MotionControl> , (VisualServoing[lbl1] # DistDetector) ; <CloseGripper>")
  T.ok(run:is_running("CloseGripper"))
  T.ok(not run:is_running("DistDetector"))
end)

suite:case("log_keeps_commands_and_ignored_events", function()
  local run = assert(algebra.new("A[l] # B"))
  run:start(7)
  run:event("B", "done")
  run:event("A", "done")
  T.eq(run:log(), { "+A[l]", "start A[l] init=7", "start B init=7", "event B done", "abort A", "-A[l]",
                    "ignored A done" })
  local long = assert(algebra.new("P :; Q"))
  long:start()
  for _ = 1, 1000 do long:event("P", "done"); long:event("Q", "done") end
  local entries = long:log()
  T.eq(#entries, 256)
  T.eq(entries[#entries], "start P")
end)

suite:case("conflict_is_reported_through_log_command", function()
  local lines = {}
  local run = assert(algebra.new("A", { is_running = function() return true end,
                                        log = function(s) lines[#lines + 1] = s end }))
  T.eq(run:start(), false)
  T.eq(lines, { "process A already running: occurrence aborted" })
end)

suite:case("tostring_round_trips", function()
  for _, s in ipairs({ "A", "A[l]", "A , B ; C # D : E :; F", "((A , B) , C) ; (D ; E)", "(A # B) # C",
                       "A : (B : C) :; D", "(A ; B) : C", "A # (B , C) ; D" }) do
    local e = assert(algebra.parse(s))
    local text = algebra.tostring(e)
    local e2 = assert(algebra.parse(text))
    T.eq(algebra.tostring(e2), text, s)
  end
end)

return suite:run(...)
