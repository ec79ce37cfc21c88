-- dca.testing: a small test framework for Lua tests (tests/lua/*_test.lua), run by `dca lua`.
--
--   local T = require "dca.testing"
--   local suite = T.suite("embed")
--   suite:case("runs_a_chunk", function() T.eq(1 + 1, 2) end)
--   return suite:run(...)
--
-- `dca lua FILE --list` prints the case names (CTest registers one test per case);
-- `dca lua FILE --case NAME` runs one; no argument runs all. Output: one "ok"/"FAIL" line per case and
-- the closing line "N passed, N failed". The returned exit code is 0 only when every case passed.
local M = {}

local fmt, concat, sort = string.format, table.concat, table.sort
local type, pairs, ipairs, tostring, pcall, xpcall = type, pairs, ipairs, tostring, pcall, xpcall
local traceback = debug.traceback

--- A readable, deterministic rendering of any Lua value (tables with sorted keys).
function M.show(v, seen)
  local tv = type(v)
  if tv == "string" then return fmt("%q", v) end
  if tv ~= "table" then return tostring(v) end
  seen = seen or {}
  if seen[v] then return "<cycle>" end
  seen[v] = true
  local keys = {}
  for k in pairs(v) do keys[#keys + 1] = k end
  sort(keys, function(a, b)
    local ta, tb = type(a), type(b)
    if ta ~= tb then return ta < tb end
    if ta == "number" or ta == "string" then return a < b end
    return tostring(a) < tostring(b)
  end)
  local parts, n = {}, #v
  for _, k in pairs(keys) do
    if math.type(k) == "integer" and k >= 1 and k <= n then
      parts[#parts + 1] = M.show(v[k], seen)
    elseif type(k) == "string" and k:match("^[%a_][%w_]*$") then
      parts[#parts + 1] = k .. " = " .. M.show(v[k], seen)
    else
      parts[#parts + 1] = "[" .. M.show(k, seen) .. "] = " .. M.show(v[k], seen)
    end
  end
  seen[v] = nil
  return "{ " .. concat(parts, ", ") .. " }"
end

--- Deep equality of two values (tables compared by content).
function M.equal(a, b)
  if a == b then return true end
  if type(a) ~= "table" or type(b) ~= "table" then return false end
  for k, va in pairs(a) do
    if not M.equal(va, b[k]) then return false end
  end
  for k in pairs(b) do
    if a[k] == nil then return false end
  end
  return true
end

local function fail(msg, level) error(msg, (level or 1) + 2) end

--- Fails unless `actual` deep-equals `expected`.
function M.eq(actual, expected, what)
  if not M.equal(actual, expected) then
    fail(fmt("%sexpected %s\n       got %s", what and (what .. ": ") or "", M.show(expected), M.show(actual)))
  end
end

--- Fails unless `v` is truthy.
function M.ok(v, what)
  if not v then fail(what or "expected a true value") end
  return v
end

--- Fails unless the string `s` contains `fragment` (plain text).
function M.contains(s, fragment, what)
  if type(s) ~= "string" or not s:find(fragment, 1, true) then
    fail(fmt("%sexpected text containing %q\n       got %s", what and (what .. ": ") or "", fragment, M.show(s)))
  end
end

--- Fails unless fn(...) raises an error; returns the error message.
function M.raises(fn, ...)
  local ok, err = pcall(fn, ...)
  if ok then fail("expected an error, none was raised") end
  return err
end

--- Runs a shell command; returns its output (stdout and stderr) and its exit code.
function M.sh(cmd)
  local p = assert(io.popen(cmd .. " 2>&1; echo \"<<rc=$?>>\"", "r"))
  local out = p:read("a")
  p:close()
  local body, rc = out:match("^(.*)<<rc=(%d+)>>%s*$")
  return body or out, tonumber(rc)
end

--- The repository's root ($DCA_SOURCE_DIR, else ".") and the dca executable ($DCA_EXE, else "dca").
M.src = os.getenv("DCA_SOURCE_DIR") or "."
M.exe = os.getenv("DCA_EXE") or "dca"
-- The sanitizer build's suite (DCA_SANITIZED=1 from tests/CMakeLists.txt): a test that repeats one code path many
-- times (generated inputs, moments of a start-up) may take fewer there, where each process is several times slower.
M.sanitized = os.getenv("DCA_SANITIZED") == "1"

--- The whole text of the file at path (it must read).
function M.read(path)
  local f = assert(io.open(path, "rb"))
  local text = f:read("a")
  f:close()
  return text
end

--- The messages of an MCAP recording (compressed or not), read by dca's reader: their data, one a line.
function M.mcap_text(path)
  local rec = assert(require("dca.core").mcap_read(path))
  local out = {}
  for i, m in ipairs(rec.messages) do out[i] = m.data end
  return table.concat(out, "\n")
end

--- Writes text to the file at path (it must write). --> path
function M.write(path, text)
  local f = assert(io.open(path, "w"))
  f:write(text)
  f:close()
  return path
end

--- Whether a file or folder exists at path.
function M.exists(path)
  local f = io.open(path, "rb")
  if f then f:close() end
  return f ~= nil
end

--- Waits (bounded: `timeout` s of wall-clock time) until the file at `path` holds the Lua pattern `pattern` (the
--- output of a process a test started in the background). --> its text, or nil at the deadline
function M.wait_for(path, pattern, timeout)
  local deadline = os.time() + timeout
  repeat
    local f = io.open(path)
    local text = f and f:read("a") or ""
    if f then f:close() end
    if text:find(pattern) then return text end
    os.execute("sleep 0.05")
  until os.time() > deadline
end

--- Starts the shell command `cmd` in the background, its output (both streams) to the file `log`. --> its pid
function M.background(cmd, log)
  local p = assert(io.popen(cmd .. " > " .. log .. " 2>&1 & echo $!"))
  local pid = tonumber(p:read("a"):match("%d+"))
  p:close()
  return pid
end

--- Waits (bounded: `timeout` s of wall-clock time) until the process `pid` has exited. --> whether it has
function M.wait_exit(pid, timeout)
  local deadline = os.time() + timeout
  while os.execute("kill -0 " .. pid .. " 2>/dev/null") and os.time() <= deadline do os.execute("sleep 0.05") end
  return not os.execute("kill -0 " .. pid .. " 2>/dev/null")
end

--- The folder of the file that calls it (a test's own folder, for the files beside it).
function M.here()
  return debug.getinfo(2, "S").source:match("^@(.*)/[^/]*$") or "."
end

--- The names in the folder dir that match the Lua pattern (default: all), sorted.
function M.list(dir, pattern)
  local p = assert(io.popen("ls -A '" .. dir .. "' 2>/dev/null"))
  local names = {}
  for name in p:lines() do
    if not pattern or name:match(pattern) then names[#names + 1] = name end
  end
  p:close()
  sort(names)
  return names
end

--- Fails unless `got` equals the text of the golden file at path. With DCA_GOLDEN_UPDATE=1 it writes `got` to
--- the file instead (review the diff!).
function M.golden(path, got, what)
  if os.getenv("DCA_GOLDEN_UPDATE") == "1" then
    M.write(path, got)
    return
  end
  if not M.exists(path) then fail("no golden file " .. path .. " (DCA_GOLDEN_UPDATE=1 writes it; review it)") end
  M.eq(got, M.read(path), what)
end

-- Temporary files: every path handed out lies in one folder made on first use in $TMPDIR (else /tmp), and
-- that folder goes when the case ends (Suite:run calls M.cleanup after each case; a script that runs no suite
-- calls it itself), so a test leaves nothing in the temporary directory.
local scratch, made = nil, 0

--- A fresh path in the scratch folder, its name ending in ext (default none); nothing is created there. --> path
function M.tmpname(ext)
  if not scratch then
    local out, rc = M.sh('mktemp -d "${TMPDIR:-/tmp}/dca_test.XXXXXX"')
    if rc ~= 0 then error("cannot make a temporary folder: " .. out, 2) end
    scratch = out:gsub("%s+$", "")
  end
  made = made + 1
  return fmt("%s/tmp%d%s", scratch, made, ext or "")
end

--- A new empty folder in the scratch folder. --> its path
function M.tmpdir()
  local dir = M.tmpname()
  assert(os.execute("mkdir '" .. dir .. "'"), "cannot make " .. dir)
  return dir
end

--- A new temporary file holding text, its name ending in ext (default ".dca"). --> its path
function M.tmpfile(text, ext) return M.write(M.tmpname(ext or ".dca"), text) end

--- Removes the scratch folder and everything in it (every path M.tmpname has handed out).
function M.cleanup()
  if scratch then os.execute("rm -rf '" .. scratch .. "'") end
  scratch = nil
end

--- The folder where a failed `dca run` kept its daemons' logs, named in its output `out` (nil when none), and
--- removed unless `keep`: a test leaves nothing in the temporary directory. --> path | nil
function M.kept_logs(out, keep)
  local dir = out:match("the logs of this run's daemons are kept in (%S+)/ %(")
  if dir and not keep then os.execute("rm -rf '" .. dir .. "'") end
  return dir
end

--- Runs `dca ARGS` (M.exe); fails unless it exits with rc (unless nil) and its output (stdout and stderr)
--- contains each fragment. --> output, exit code
function M.dca(args, rc, ...)
  local out, code = M.sh(M.exe .. " " .. args)
  if rc ~= nil and code ~= rc then fail(fmt("dca %s: expected exit code %d, got %s:\n%s", args, rc, tostring(code), out)) end
  for _, fragment in ipairs({ ... }) do M.contains(out, fragment, "dca " .. args) end
  return out, code
end

--- Runs loop (a dca.core loop) until pred() holds, at most `seconds` (default 10); fails naming `what` else.
function M.wait(loop, pred, what, seconds)
  if not loop:run_until(pred, seconds or 10) then fail("timed out waiting for " .. what) end
end

local Suite = {}
Suite.__index = Suite

--- A new suite; `name` prefixes its cases in reports.
function M.suite(name)
  return setmetatable({ name = name, cases = {}, by_name = {} }, Suite)
end

--- Adds a case. Names are words ([%w_.-]), unique within the suite, so CTest can name a test after each.
function Suite:case(name, fn)
  assert(type(name) == "string" and name:match("^[%w_.%-]+$"), "case name must be a word: " .. tostring(name))
  assert(not self.by_name[name], "duplicate case name: " .. name)
  self.by_name[name] = fn
  self.cases[#self.cases + 1] = name
end

local function run_case(fn)
  return xpcall(fn, function(e) return traceback(tostring(e), 2) end)
end

--- Runs the suite with the command-line words `...` (see the header). Returns the exit code.
function Suite:run(...)
  local args = { ... }
  if args[1] == "--list" then
    for _, n in ipairs(self.cases) do io.write(n, "\n") end
    M.cleanup()
    return 0
  end
  local selected = self.cases
  if args[1] == "--case" then
    if not self.by_name[args[2]] then
      io.stderr:write(fmt("%s: no case named %q\n", self.name, tostring(args[2])))
      return 2
    end
    selected = { args[2] }
  end
  local passed, failed = 0, 0
  for _, n in ipairs(selected) do
    local ok, err = run_case(self.by_name[n])
    M.cleanup()
    if ok then
      passed = passed + 1
      io.write("ok   ", self.name, ".", n, "\n")
    else
      failed = failed + 1
      io.write("FAIL ", self.name, ".", n, "\n  ", (tostring(err):gsub("\n", "\n  ")), "\n")
    end
  end
  io.write(fmt("%d passed, %d failed\n", passed, failed))
  io.flush()
  return failed == 0 and 0 or 1
end

return M
