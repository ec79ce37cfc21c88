-- The team's acceptance cases for the algebra, carried in the repository (tests/lua/cases/algebra.lua, a copy of
-- shared/cases/algebra.lua; format in its header), each registered as one case under its own name: CTest shows
-- lua.algebra_cases.<name>. Where the team's shared/ folder is beside the clone ($DCA_SHARED_DIR), one more case
-- checks that the carried copy still equals it; elsewhere that case is not registered.
local T = require "dca.testing"
local algebra = require "dca.algebra"
local suite = T.suite("algebra_cases")

local carried = T.here() .. "/cases/algebra.lua"
local cases = assert(dofile(carried), carried .. " returns no table")
assert(type(cases) == "table" and #cases > 0, carried .. " holds no cases")

local shared = os.getenv("DCA_SHARED_DIR")
local shared_cases = shared and shared ~= "" and shared .. "/cases/algebra.lua"
if shared_cases and T.exists(shared_cases) then
  suite:case("carried_copy_equals_shared", function()
    T.ok(T.read(carried) == T.read(shared_cases),
         carried .. " differs from " .. shared_cases .. ": copy the shared file over the carried one")
  end)
end

-- Drives one case through the interpreter and returns what was observed, in the cases' vocabulary.
local function drive(c)
  local seen = { started = {}, aborted = {}, inits = {}, labels = {}, order = {}, ignored = {} }
  local expr, err = algebra.parse(c.expr)
  if not expr then
    seen.final, seen.error = "error", err
    return seen
  end
  local before = {}
  for _, n in ipairs(c.running_before or {}) do before[n] = true end
  local current_label = {}
  -- A label set switched on ("+") or off ("-"), recorded in both logs.
  local function switch(sign, name, label)
    current_label[name] = sign == "+" and label or nil
    local s = sign .. name .. "[" .. label .. "]"
    seen.labels[#seen.labels + 1] = s
    seen.order[#seen.order + 1] = s
  end
  local run = algebra.new(expr, {
    start = function(name, init)
      local lb = current_label[name]
      local s = lb and (name .. "[" .. lb .. "]") or name
      seen.started[#seen.started + 1] = s
      seen.order[#seen.order + 1] = "start " .. s
      if init ~= nil then seen.inits[#seen.inits + 1] = { name, init } end
    end,
    abort = function(name)
      seen.aborted[#seen.aborted + 1] = name
      seen.order[#seen.order + 1] = "abort " .. name
    end,
    activate = function(name, label) switch("+", name, label) end,
    deactivate = function(name, label) switch("-", name, label) end,
    is_running = function(name) return before[name] == true end,
  })
  run:start()
  -- stable sort of the script by t
  local script = {}
  for i, s in ipairs(c.script or {}) do script[i] = { t = s.t, i = i, ev = s.ev } end
  table.sort(script, function(a, b) if a.t ~= b.t then return a.t < b.t end return a.i < b.i end)
  for _, s in ipairs(script) do
    local name, kind, v = s.ev[1], s.ev[2], s.ev[3]
    if name == "*" then
      T.eq(kind, "abort", "the only event of '*' is abort")
      run:abort()
    else
      local taken = run:event(name, kind, v)
      T.ok(taken == true or taken == false, "event() returns a boolean")
      if not taken then seen.ignored[#seen.ignored + 1] = name .. " " .. kind end
    end
  end
  seen.final, seen.value = run:status()
  seen.running = run:running()
  return seen
end

for _, c in ipairs(cases) do
  suite:case(c.name, function()
    local x = c.expect
    local got = drive(c)
    T.eq(got.final, x.final, "final")
    if x.final == "error" then
      T.contains(got.error:lower(), x.error:lower(), "error message")
    end
    T.eq(got.started, x.started, "started")
    T.eq(got.aborted, x.aborted, "aborted")
    if x.value ~= nil then T.eq(got.value, x.value, "value") end
    for _, k in ipairs({ "inits", "labels", "order", "running", "ignored" }) do
      if x[k] ~= nil then T.eq(got[k], x[k], k) end
    end
  end)
end

return suite:run(...)
