-- dca.reload: nothing reaches the running system unless it loads; what does replaces the old version.
local T = require "dca.testing"
local reload = require "dca.reload"
local suite = T.suite("reload")

--- A stand-in for the root supervisor: records the specs it is given.
local function stub()
  return { specs = {}, update = function(self, spec, cb) self.specs[#self.specs + 1] = spec cb({ "updated" }) end }
end

suite:case("a_system_file_that_checks_reaches_the_supervisor", function()
  local sup, got = stub(), nil
  reload.system(sup, T.src .. "/scripts/systems/door_open.dca", {}, function(lines, err) got = { lines, err } end)
  T.eq(got, { { "updated" } })
  T.eq(#sup.specs, 1)
  T.eq(sup.specs[1].path, "main")
end)

suite:case("a_broken_system_file_is_refused_with_file_line_col", function()
  local sup, lines, err = stub(), nil, nil
  local path = T.tmpfile("process main() {\n  instantiated_processes { a instof Timer(\"h\", 1); }\n" ..
                         "  internal_event_actions { a ; nosuch }\n}\n")
  reload.system(sup, path, {}, function(l, e) lines, err = l, e end)
  os.remove(path)
  T.eq(lines, nil)
  T.contains(err, path .. ":3:32: main: unknown instance 'nosuch'")
  T.eq(#sup.specs, 0, "the supervisor saw nothing")
end)

--- A module file named dca_reload_probe_<n> in a fresh directory on package.path; returns its name and writer.
local function probe_module()
  local dir = os.tmpname()
  os.remove(dir)
  assert(os.execute("mkdir -p '" .. dir .. "'"))
  local name = "dca_reload_probe"
  package.path = dir .. "/?.lua;" .. package.path
  local function write(text)
    local f = assert(io.open(dir .. "/" .. name .. ".lua", "w"))
    f:write(text)
    f:close()
  end
  return name, write, dir
end

suite:case("modules_are_replaced_only_when_they_compile_and_run", function()
  local name, write, dir = probe_module()
  write("return { version = 1 }")
  T.eq(require(name).version, 1)
  write("return { version = 2 }")
  T.eq(reload.modules({ name }), { name .. ": reloaded (state kept)" })
  T.eq(package.loaded[name].version, 2)
  write("return { version = ")
  local lines = reload.modules({ name })
  T.contains(lines[1], name .. ".lua:1:")
  T.eq(package.loaded[name].version, 2, "a module that does not compile is kept as it was")
  write("error('boom')")
  T.contains(reload.modules({ name })[1], "boom")
  T.eq(package.loaded[name].version, 2, "a module that fails to run is kept as it was")
  os.execute("rm -rf '" .. dir .. "'")
end)

suite:case("the_default_modules_are_the_supervisor_and_its_console", function()
  T.eq(reload.MODULES, { "dca.supervisor", "dca.supervisor.console" })
end)

return suite:run(...)
