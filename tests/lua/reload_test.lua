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
  reload.system(sup, T.src .. "/worlds/door/systems/door_open.dca", {}, function(lines, err) got = { lines, err } end)
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
  local dir = T.tmpdir()
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

suite:case("the_default_modules_are_every_supervisor_module_the_supervisor_last", function()
  require "dca.supervisor"
  local names = reload.default_modules()
  T.eq(names[#names], "dca.supervisor")
  local set = {}
  for _, n in ipairs(names) do set[n] = true end
  for _, m in ipairs({ "child", "console", "policy", "requests", "restart", "spec", "taps", "wiring" }) do
    T.ok(set["dca.supervisor." .. m], "dca.supervisor." .. m .. " is reloaded")
  end
end)

--- The supervisor's Lua files copied into a fresh directory put first on package.path. --> the copy of
--- dca/supervisor, and a function that puts package.path back and removes the directory
local function supervisor_copy()
  local from = package.searchpath("dca.supervisor.policy", package.path):match("^(.*)/policy%.lua$")
  local dir = os.tmpname()
  os.remove(dir)
  assert(os.execute("mkdir -p '" .. dir .. "/dca' && cp -r '" .. from .. "' '" .. dir .. "/dca/supervisor'"))
  local saved = package.path
  package.path = dir .. "/?.lua;" .. dir .. "/?/init.lua;" .. package.path
  return dir .. "/dca/supervisor", function()
    package.path = saved
    os.execute("rm -rf '" .. dir .. "'")
  end
end

suite:case("an_edit_to_policy_lua_reaches_a_running_supervisor", function()
  local fake = require "dca.supervisor.memory"
  local spec = fake.root("main", "h1", "a , b", { fake.leaf("a", "Run", "h1"), fake.leaf("b", "Run", "h1") })
  spec.supervision = { strategy = "one_for_one", intensity = 3, within = 10, on = { aborted = true } }
  local c = fake.cluster({ behave = {} })
  c:root(spec)
  assert(c:configure())
  c:start()
  c:settle(c.t + 1)
  local dir, restore = supervisor_copy()
  local ok, err = pcall(function()
    local f = assert(io.open(dir .. "/policy.lua"))
    local text = f:read("a")
    f:close()
    local edited, n = text:gsub('return sformat%("%%d in %%g s", pol.intensity, pol.within%)',
      'return sformat("%%d per %%g s (edited)", pol.intensity, pol.within)')
    T.eq(n, 1, "policy.budget found")
    f = assert(io.open(dir .. "/policy.lua", "w"))
    f:write(edited)
    f:close()
    for _, line in ipairs(reload.modules()) do T.contains(line, ": reloaded (state kept)") end
    c.root_sup:child_message("b", { type = "aborted", reason = "sensor fault" })
    c:settle(c.t + 1)
    T.contains(table.concat(c.lines, "\n"), "restarting b (1/3 per 10 s (edited))")
  end)
  restore()
  reload.modules()   -- the tree's own version again
  if not ok then error(err, 0) end
end)

return suite:run(...)
