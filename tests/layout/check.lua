-- The layout rules of ARCHITECTURE.md, measured: run by CTest as layout.<rule>, and by hand as
--   scripts/layout-check            every case, naming each offender
--   scripts/layout-check --report   the figures: longest functions, files per folder
-- It reads the tree as text; C++ functions are found by universal-ctags, Lua functions by luac5.4's listing.
local T = require "dca.testing"

local fmt, concat, sort = string.format, table.concat, table.sort

local MAX_LINES = 80
local root = os.getenv("DCA_SOURCE_DIR") or "."

--- The lines a shell command prints (it must succeed).
local function lines_of(cmd)
  local p = assert(io.popen(cmd))
  local out = {}
  for l in p:lines() do out[#out + 1] = l end
  local ok, _, code = p:close()
  if not ok then error(fmt("'%s' failed (exit %s)", cmd, tostring(code)), 2) end
  return out
end

--- The files git tracks under the folders given, matching a Lua pattern on the path.
local function files(folders, pattern)
  local list = {}
  for _, f in ipairs(lines_of(fmt("cd '%s' && git ls-files -- %s", root, concat(folders, " ")))) do
    if f:match(pattern) then list[#list + 1] = f end
  end
  return list
end

--- Every C++ function definition (lambdas too) in the files: {file, name, first, last}.
local function cxx_functions(paths)
  local out = {}
  if #paths == 0 then return out end
  local cmd = fmt("cd '%s' && ctags --output-format=json --fields=+ne --kinds-C++=f --language-force=C++ -o - %s",
                  root, concat(paths, " "))
  for _, l in ipairs(lines_of(cmd)) do
    local path, name = l:match('"path": "([^"]+)"'), l:match('"name": "([^"]+)"')
    local first, last = tonumber(l:match('"line": (%d+)')), tonumber(l:match('"end": (%d+)'))
    if path and first and last then
      local scope = l:match('"scope": "([^"]+)"')
      if name:match("^__anon") then name = "lambda in " .. (scope or "?")
      elseif scope then name = (scope .. "::" .. name):gsub("__anon%w+::", "") end
      out[#out + 1] = { file = path, name = name, first = first, last = last }
    end
  end
  return out
end

--- Every Lua function in the files: {file, name, first, last} (luac names none: the first line stands in).
local function lua_functions(paths)
  local out = {}
  for _, path in ipairs(paths) do
    for _, l in ipairs(lines_of(fmt("cd '%s' && luac5.4 -p -l '%s'", root, path))) do
      local first, last = l:match("^function <[^:]+:(%d+),(%d+)>")
      if first then
        out[#out + 1] = { file = path, name = "function", first = tonumber(first), last = tonumber(last) }
      end
    end
  end
  return out
end

--- The functions of the measured folders, longest first.
local function measured_functions()
  local all = cxx_functions(files({ "host", "app", "bindings" }, "%.[ch]p?p?$"))
  for _, f in ipairs(lua_functions(files({ "lua/dca" }, "%.lua$"))) do all[#all + 1] = f end
  for _, f in ipairs(all) do f.lines = f.last - f.first + 1 end
  sort(all, function(a, b) return a.lines > b.lines end)
  return all
end

local function describe(f) return fmt("%s:%d-%d %s (%d lines)", f.file, f.first, f.last, f.name, f.lines) end

--- Fails listing every offender, one per line.
local function none(offenders, what)
  if #offenders > 0 then error(fmt("%d %s:\n  %s", #offenders, what, concat(offenders, "\n  ")), 0) end
end

--- The `require`d module names of a Lua file.
local function requires(path)
  local fh = assert(io.open(root .. "/" .. path))
  local src = fh:read("a")
  fh:close()
  local mods = {}
  for m in src:gmatch("require%s*%(?%s*[\"']([%w%._]+)[\"']") do mods[#mods + 1] = m end
  for m in src:gmatch("pcall%s*%(%s*require%s*,%s*[\"']([%w%._]+)[\"']") do mods[#mods + 1] = m end
  return mods
end

local suite = T.suite("layout")

suite:case("no_function_longer_than_80_lines", function()
  local long = {}
  for _, f in ipairs(measured_functions()) do
    if f.lines > MAX_LINES then long[#long + 1] = describe(f) end
  end
  none(long, fmt("functions in host/, app/, bindings/ and lua/dca/ are longer than %d lines", MAX_LINES))
end)

suite:case("host_includes_only_host", function()
  local bad = {}
  for _, path in ipairs(files({ "host" }, "%.[ch]p?p?$")) do
    local n = 0
    for l in io.lines(root .. "/" .. path) do
      n = n + 1
      local inc = l:match('^%s*#%s*include%s*"([^"]+)"')
      if inc and (inc:match("^bindings/") or inc:match("^controllers/") or inc:match("^sim/") or inc:match("^app/")) then
        bad[#bad + 1] = fmt("%s:%d: %s", path, n, inc)
      end
    end
  end
  none(bad, "includes in host/ reach outside it")
end)

suite:case("only_the_cli_requires_dca_cli", function()
  local bad = {}
  for _, path in ipairs(files({ "lua/dca" }, "%.lua$")) do
    if not path:match("^lua/dca/cli/") then
      for _, m in ipairs(requires(path)) do
        if m:match("^dca%.cli%.") then bad[#bad + 1] = path .. " requires " .. m end
      end
    end
  end
  none(bad, "modules outside lua/dca/cli/ require dca.cli.*")
end)

suite:case("the_supervisor_engine_needs_no_core_and_no_console", function()
  local engine = files({ "lua/dca/supervisor" }, "^lua/dca/supervisor/init%.lua$")[1]
                 or files({ "lua/dca" }, "^lua/dca/supervisor%.lua$")[1]
  T.ok(engine, "the supervisor engine's file")
  local bad = {}
  for _, m in ipairs(requires(engine)) do
    if m == "dca.core" or m:match("console") or m:match("repl") then bad[#bad + 1] = engine .. " requires " .. m end
  end
  none(bad, "requires in the supervisor engine")
end)

--- The includes of the C++ files under `folders` (but not of the files matching a pattern of `except`) that
--- `wrong(included path)` rejects, as "file:line: included".
local function bad_includes(folders, except, wrong)
  local bad = {}
  for _, path in ipairs(files(folders, "%.[ch]p?p?$")) do
    local skip = false
    for _, e in ipairs(except) do skip = skip or path:match(e) ~= nil end
    local n = 0
    for l in skip and function() end or io.lines(root .. "/" .. path) do
      n = n + 1
      local inc = l:match('^%s*#%s*include%s*"([^"]+)"') or l:match("^%s*#%s*include%s*<([^>]+)>")
      if inc and wrong(inc) then bad[#bad + 1] = fmt("%s:%d: %s", path, n, inc) end
    end
  end
  return bad
end

suite:case("host_codec_is_pure", function()
  none(bad_includes({ "host/codec" }, {}, function(p)
    return p:match("^boost/asio") or p:match("^boost/beast") or p:match("^host/net/") or p:match("^host/web/")
           or p == "host/loop.h"
  end), "includes in host/codec/ reach Asio, Beast, host/net or host/web")
end)

suite:case("only_web_its_bindings_and_taps_include_host_web", function()
  none(bad_includes({ "host", "bindings", "app", "controllers", "sim", "examples" },
                    { "^host/web/", "^bindings/wrap_web", "^bindings/wrap_taps" },
                    function(p) return p:match("^host/web/") or p:match("^boost/beast") end),
       "files outside host/web/, bindings/wrap_web* and bindings/wrap_taps* include host/web or Beast")
end)

--- A standard library header: <cstdint>, <string> (no folder, no extension).
local function standard(p) return not p:match("/") and not p:match("%.") end

suite:case("sdk_headers_include_only_the_sdk", function()
  none(bad_includes({ "sdk/include" }, {}, function(p)
    return not (p:match("^dca/") or p:match("^Eigen/") or p:match("^msgpack") or standard(p))
  end), "SDK headers (sdk/include/dca/) include something other than the SDK, the standard library, Eigen or msgpack")
end)

-- A package built in the tree like a user's: its files include only the SDK, the standard library and `own`.
local function package_includes_only(folders, own, what)
  none(bad_includes(folders, {}, function(p)
    for _, ok in ipairs(own) do
      if p:match(ok) then return false end
    end
    return not standard(p)
  end), what .. " includes what an installed dca lacks")
end

suite:case("the_door_package_includes_only_the_sdk_and_its_own", function()
  package_includes_only({ "controllers/door", "controllers/math", "controllers/robot/model.h", "controllers/robot/model.cpp" },
    { "^door/", "^math/", "^robot/model%.h$", "^dca/", "^Eigen/", "^urdf_model/", "^urdf_parser/" },
    "the door package (controllers/door, math, robot/model.*)")
end)

suite:case("the_joint_control_package_includes_only_the_sdk_and_its_own", function()
  package_includes_only({ "controllers/joint_control" }, { "^joint_[%w_]+%.h$", "^dca/", "^Eigen/" },
    "the joint_control package (controllers/joint_control)")
end)

suite:case("the_ros2_package_includes_only_the_sdk_cyclone_and_its_own", function()
  package_includes_only({ "controllers/ros2" },
    { "^base%.h$", "^bridge%.h$", "^dds%.h$", "^graph%.h$", "^joint_states%.h$", "^link_frames%.h$", "^stamp%.h$",
      "^dca/", "^Eigen/", "^dds/",
      "^dlfcn%.h$" },
    "the ros2 package (controllers/ros2: the SDK, Cyclone DDS's dds/ and its own)")
end)

suite:case("host_layer_headers_state_their_rule", function()
  local bad = {}
  for _, layer in ipairs({ "codec", "net", "web" }) do
    for _, path in ipairs(files({ "host/" .. layer }, "%.h$")) do
      local fh = assert(io.open(root .. "/" .. path))
      local first, second = fh:read("l"), fh:read("l")
      fh:close()
      local rule = first == "#pragma once" and second or first
      if not (rule or ""):match("^// host/" .. layer .. ": ") then
        bad[#bad + 1] = fmt("%s: does not open with the rule line \"// host/%s: ...\"", path, layer)
      end
    end
  end
  none(bad, "headers of host/codec, host/net and host/web without their folder's rule line")
end)

suite:case("outside_worlds_no_lua_and_no_app_file_names_a_world", function()
  local bad = {}
  local function scan(path, code)
    local n = 0
    for l in (code .. "\n"):gmatch("([^\n]*)\n") do
      n = n + 1
      if l:lower():find("door", 1, true) then bad[#bad + 1] = fmt("%s:%d: %s", path, n, l:match("^%s*(.-)%s*$")) end
    end
  end
  for _, path in ipairs(files({ "lua/dca" }, "%.lua$")) do
    local fh = assert(io.open(root .. "/" .. path))
    local src = fh:read("a")
    fh:close()
    -- comments and long strings blanked line for line, so that the line numbers stay
    local function blank(c) return (c:gsub("[^\n]", "")) end
    local code = src:gsub("(%-%-%[(=*)%[.-%]%2%])", blank)
    code = code:gsub("(%[(=*)%[.-%]%2%])", blank)
    scan(path, (code:gsub("%-%-[^\n]*", "")))
  end
  for _, path in ipairs(files({ "app" }, "")) do
    local fh = assert(io.open(root .. "/" .. path))
    local src = fh:read("a")
    fh:close()
    scan(path, (src:gsub("//[^\n]*", ""):gsub("#[^\n]*", function(c) return path:match("CMakeLists") and "" or c end)))
  end
  -- the monitor page's own files (its npm dependencies are not tracked): block and line comments blanked
  for _, path in ipairs(files({ "lua/dca/monitor/page" }, "%.%w+$")) do
    if path:match("%.js$") or path:match("%.html$") then
      local fh = assert(io.open(root .. "/" .. path))
      local src = fh:read("a")
      fh:close()
      local code = src:gsub("/%*.-%*/", function(c) return (c:gsub("[^\n]", "")) end)
      code = code:gsub("<!%-%-.-%-%->", function(c) return (c:gsub("[^\n]", "")) end)
      scan(path, (code:gsub("([^:])//[^\n]*", "%1"):gsub("^//[^\n]*", "")))
    end
  end
  none(bad, "lines outside worlds/ name a world (docs/worlds.md)")
end)

suite:case("child_states_change_only_through_child_set", function()
  -- a child record (dca.supervisor.child) is `ch` or `....children[name]`; its state is set by child.set only
  local bad = {}
  for _, path in ipairs(files({ "lua/dca" }, "%.lua$")) do
    if path ~= "lua/dca/supervisor/child.lua" then
      local n = 0
      for l in io.lines(root .. "/" .. path) do
        n = n + 1
        local code = l:gsub("%-%-.*$", "")
        -- `ch.state = `, `children[name].state = `, and `ch.state, x.y = ` (one of several targets, a statement)
        local several = false
        for stmt in (" " .. code):gsub("%f[%w_]then%f[^%w_]", "\n"):gsub("%f[%w_]do%f[^%w_]", "\n"):gmatch("[^\n]+") do
          several = several or stmt:match("^%s*[%w_%.%[%],%s]-%f[%w_]ch%.state%s*,[%w_%.%[%],%s]*=[^=]") ~= nil
        end
        if code:match("%f[%w_]ch%.state%s*=[^=]") or code:match("children%b[]%.state%s*=[^=]") or several then
          bad[#bad + 1] = fmt("%s:%d: %s", path, n, l:match("^%s*(.-)%s*$"))
        end
      end
    end
  end
  none(bad, "assignments to a child's state outside dca.supervisor.child (use child.set)")
end)

--- The figures for a note: the longest functions and the files per folder.
local function report()
  local fs = measured_functions()
  local over = 0
  for _, f in ipairs(fs) do if f.lines > MAX_LINES then over = over + 1 end end
  print(fmt("functions measured: %d; longer than %d lines: %d", #fs, MAX_LINES, over))
  for i = 1, math.min(10, #fs) do print("  " .. describe(fs[i])) end
  local per = {}
  for _, f in ipairs(files({ "." }, ".")) do
    local dir = f:match("^(.*)/[^/]+$") or "."
    per[dir] = (per[dir] or 0) + 1
  end
  local dirs = {}
  for d in pairs(per) do dirs[#dirs + 1] = d end
  sort(dirs)
  print("files per folder:")
  for _, d in ipairs(dirs) do print(fmt("  %4d %s", per[d], d)) end
  return 0
end

if ... == "--report" then return report() end
return suite:run(...)
