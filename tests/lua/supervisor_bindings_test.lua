-- The bindings the supervisor's tools use: file watching (dca run --watch) and line reading (dca repl).
local T, core = require "dca.testing", require "dca.core"
local suite = T.suite("supervisor_bindings")

local dca = os.getenv("DCA_EXE") or "dca"

suite:case("watch_file_sees_a_write_and_a_save_by_rename_and_nothing_else", function()
  local path = T.write(T.tmpname(".dca"), "")
  local w = assert(core.watch_file(path))
  T.eq(w:changed(), false)
  local f = assert(io.open(path, "w")) f:write("x") f:close()
  T.eq(w:changed(), true)
  T.eq(w:changed(), false, "reported once")
  local other = assert(io.open(path .. ".other", "w")) other:write("y") other:close()
  T.eq(w:changed(), false, "another file in the directory")
  local tmp = assert(io.open(path .. ".new", "w")) tmp:write("z") tmp:close()
  os.rename(path .. ".new", path)
  T.eq(w:changed(), true, "replaced by rename, as editors save")
  w:close()
  T.contains(tostring(w), "closed")
  os.remove(path) os.remove(path .. ".other")
end)

suite:case("watch_file_names_a_missing_directory", function()
  local w, err = core.watch_file("/nonexistent-dir-for-dca/x.dca")
  T.eq(w, nil)
  T.contains(err, "/nonexistent-dir-for-dca")
end)

suite:case("readline_reads_lines_and_returns_nil_at_end_of_input", function()
  local script = T.tmpname(".lua")
  local f = assert(io.open(script, "w"))
  f:write([[local core = require "dca.core"
local a, b, c = core.readline("> "), core.readline("> "), core.readline("> ")
core.add_history(a)
io.stderr:write("GOT[", tostring(a), "][", tostring(b), "][", tostring(c), "]\n")]])
  f:close()
  local out, rc = T.sh("printf 'tree()\\nreturn 1\\n' | " .. dca .. " lua " .. script)
  os.remove(script)
  T.eq(rc, 0)
  T.contains(out, "GOT[tree()][return 1][nil]")
end)

return suite:run(...)
