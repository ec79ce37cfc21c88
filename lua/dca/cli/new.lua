-- `dca new package NAME` and `dca new controller TYPE`: a controller package that builds, a controller with its
-- unit test, and a .dca system that runs it, in one command (docs/packages.md, "Start a package").
local args = require "dca.cli.args"

local M = {}

M.summary = "start a controller package, or add a controller to one (its code, its test, a system running it)"
M.usage = [[usage: dca new package NAME [DIR] [--controller TYPE]
       dca new controller TYPE [--package DIR]

`dca new package NAME` writes the controller package NAME into DIR (default ./NAME), which must not exist:
  CMakeLists.txt          builds NAME.dca.so and its tests against the installed dca (find_package(dca))
  src/<type>.cpp          the controller TYPE (default: NAME in CamelCase): Command = kp (setpoint - Measured)
  tests/<type>_test.cpp   its unit test on the fixture dca/testing/controller.h (GoogleTest)
  NAME.dca                a system running it to DONE (also a test)
  README.md               how to build, test and run it
Then: cmake -S DIR -B DIR/build -DCMAKE_PREFIX_PATH=<dca prefix> && cmake --build DIR/build && ctest --test-dir DIR/build

`dca new controller TYPE` adds src/<type>.cpp and tests/<type>_test.cpp to the package in DIR (default: the
current directory); the next build picks them up. Nothing existing is overwritten.]]

-- C++ keywords a package name (a namespace) cannot be.
local KEYWORDS = {}
for w in ([[alignas alignof and and_eq asm auto bitand bitor bool break case catch char char8_t char16_t char32_t
  class compl concept const consteval constexpr constinit const_cast continue co_await co_return co_yield decltype
  default delete do double dynamic_cast else enum explicit export extern false float for friend goto if inline int
  long mutable namespace new noexcept not not_eq nullptr operator or or_eq private protected public register
  reinterpret_cast requires return short signed sizeof static static_assert static_cast struct switch template this
  thread_local throw true try typedef typeid typename union unsigned using virtual void volatile wchar_t while xor
  xor_eq dca std]]):gmatch("%S+") do
  KEYWORDS[w] = true
end

--- Why `name` cannot be a package name, or nil.
function M.package_name_error(name)
  if not name:match("^[A-Za-z_][A-Za-z0-9_]*$") then
    return "'" .. name .. "' is not a package name: letters, digits and '_', not starting with a digit"
  end
  if KEYWORDS[name] then return "'" .. name .. "' is a C++ keyword or a reserved namespace: choose another name" end
  if #name > 64 then return "a package name has at most 64 characters" end
end

--- Why `t` cannot be a controller type name, or nil.
function M.type_name_error(t)
  if not t:match("^[A-Z][A-Za-z0-9]*$") then
    return "'" .. t .. "' is not a controller type name: a capital letter, then letters and digits (e.g. Pid)"
  end
  if #t > 64 then return "a controller type name has at most 64 characters" end
end

--- "door_tools" -> "DoorTools".
function M.camel(name)
  local s = name:gsub("_+(%w)", function(c) return c:upper() end):gsub("^_+", "")
  return (s:gsub("^%l", string.upper))
end

--- "DoorTools" -> "door_tools"; "PID2Filter" -> "pid2_filter".
function M.snake(t)
  local s = t:gsub("(%u+)(%u%l)", "%1_%2"):gsub("([%l%d])(%u)", "%1_%2")
  return s:lower()
end

local function fill(template, vars)
  return (template:gsub("{{(%w+)}}", function(k) return assert(vars[k], k) end))
end

local CONTROLLER = [[
// {{TYPE}}(host, setpoint, kp=1, period=0.01): a proportional controller on a scalar.
//   in  Measured  scalar   the measured value (0 until the first sample)
//   out Command   scalar   kp (setpoint - Measured) every period; zero when halted (an actuator)
// Written by `dca new`: replace MainCalc with your control law. The SDK: <dca/controller.h> (docs/packages.md).
#include <dca/controller.h>
#include <dca/registry.h>

namespace {{PACKAGE}} {
namespace {

// Each port and parameter is declared once: the manifest lists these, the constructor binds them.
const dca::InSpec<double> kMeasured{.name = "Measured"};
const dca::OutSpec<double> kCommand{.name = "Command", .actuator = true};  // halt() writes it zero
const dca::Param<double> kSetpoint{.name = "setpoint", .doc = "the value Measured should reach"};
const dca::Param<double> kKp{.name = "kp", .doc = "proportional gain", .def = 1, .min = 0};

}  // namespace

class {{TYPE}} final : public dca::PeriodicController {
  DCA_CONTROLLER({{TYPE}})
  void on_configure() override { y_ = 0; }  // before every run: reset
  void MainCalc() override;                  // every period: no allocation, no exceptions, no locks

  dca::In<double> measured_;
  dca::Out<double> command_;
  double setpoint_, kp_;
  double y_ = 0;
};

dca::Manifest {{TYPE}}::Describe() {
  return {.type = "{{TYPE}}",
          .doc = "a proportional controller: Command = kp (setpoint - Measured)",
          .inputs = {kMeasured},
          .outputs = {kCommand},
          .params = {kSetpoint, kKp, PeriodParam(0.01)},
          .ends = dca::Ending::Never()};  // it runs until halted
}

{{TYPE}}::{{TYPE}}(const dca::ControllerContext& ctx)
    : PeriodicController(ctx), measured_(port(kMeasured)), command_(port(kCommand)), setpoint_(param(kSetpoint)),
      kp_(param(kKp)) {}

void {{TYPE}}::MainCalc() {
  measured_.read(y_);  // New or Old: the newest sample; None: y_ stays 0
  command_.write(kp_ * (setpoint_ - y_));
}

DCA_REGISTER_CONTROLLER({{TYPE}});

}  // namespace {{PACKAGE}}
]]

local TEST = [[
// {{TYPE}} alone: no running system, a simulated clock that moves only when the test steps it
// (dca/testing/controller.h).
#include <dca/testing/controller.h>

#include <gtest/gtest.h>

#include <stdexcept>

using dca::testing::ControllerUnderTest;

TEST({{TYPE}}, CommandsKpTimesTheError) {
  ControllerUnderTest c("{{TYPE}}", {"1.0", "2.0"});  // setpoint 1, kp 2, period 0.01
  c.start();
  c.set("Measured", 0.25);
  c.step();  // one period: one MainCalc
  EXPECT_DOUBLE_EQ(c.get("Command"), 1.5);
}

TEST({{TYPE}}, CommandIsZeroAfterHalt) {
  ControllerUnderTest c("{{TYPE}}", {"1.0"});
  c.start();
  c.step();
  ASSERT_NE(c.get("Command"), 0.0);
  c.halt();
  EXPECT_EQ(c.get("Command"), 0.0);
}

TEST({{TYPE}}, ANegativeGainIsRefused) {
  EXPECT_THROW(ControllerUnderTest("{{TYPE}}", {"1.0", "-1"}), std::invalid_argument);
}
]]

local CMAKE = [[
# The controller package {{PACKAGE}} (written by `dca new package`; docs/packages.md):
#   cmake -S . -B build -DCMAKE_PREFIX_PATH=<dca prefix> && cmake --build build && ctest --test-dir build
# Every src/*.cpp is a source of the package and every tests/*_test.cpp a unit test: `dca new controller TYPE`
# adds both, and the next build picks them up.
cmake_minimum_required(VERSION 3.25)
project({{PACKAGE}} LANGUAGES CXX)

find_package(dca REQUIRED)  # the SDK: dca::sdk, dca::testing, dca_add_controller_package()

file(GLOB sources CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/src/*.cpp)
dca_add_controller_package({{PACKAGE}} SOURCES ${sources})  # build/{{PACKAGE}}.dca.so, loaded by `use {{PACKAGE}};`

enable_testing()
find_package(GTest REQUIRED)
file(GLOB tests CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/tests/*_test.cpp)
foreach(t IN LISTS tests)
  get_filename_component(n ${t} NAME_WE)
  dca_add_controller_test({{PACKAGE}}.${n} PACKAGE {{PACKAGE}} SOURCES ${t} LIBS GTest::gtest_main)
endforeach()

# The system: runs to DONE (dca run exits 0).
add_test(NAME {{PACKAGE}}.system COMMAND ${DCA_EXECUTABLE} run ${CMAKE_CURRENT_SOURCE_DIR}/{{PACKAGE}}.dca)
set_tests_properties({{PACKAGE}}.system PROPERTIES TIMEOUT 60 ENVIRONMENT "DCA_CONTROLLER_PATH=${CMAKE_CURRENT_BINARY_DIR}")
]]

local SYSTEM = [[
// {{TYPE}} in a system (written by `dca new package`): a ramp 1, 2, 3, ... is the measurement of a {{TYPE}}
// of setpoint 20 and kp 1, whose Command 20 - Count falls to 0 when the ramp reaches the setpoint: DONE from the
// Threshold. The Deadline ends it ABORTED if that has not happened within 10 s.
//   DCA_CONTROLLER_PATH=build dca run {{PACKAGE}}.dca
use {{PACKAGE}};

process main() {
  instantiated_processes {
    ramp    instof Counter("lab", 0.01);
    ctl     instof {{TYPE}}("lab", 20, 1);
    zero    instof Threshold("lab", 0, "falling");
    limit   instof Deadline("lab", 10);
  }
  internal_connections(ctl, loop) {
    ramp, Count -> ctl, Measured;
    ctl, Command -> zero, In;
  }
  internal_event_actions { (zero # limit) # (ctl[loop], ramp) }
}
]]

local README = [[
# {{PACKAGE}}

A dca controller package (written by `dca new package`). Its controllers are in `src/`, their unit tests in
`tests/`, and `{{PACKAGE}}.dca` is a system using them.

```
cmake -S . -B build -DCMAKE_PREFIX_PATH=<dca prefix> && cmake --build build
ctest --test-dir build                       # the unit tests and the system
export DCA_CONTROLLER_PATH=$PWD/build
dca types --package {{PACKAGE}}               # its controllers, ports and parameters
dca check {{PACKAGE}}.dca && dca run {{PACKAGE}}.dca
dca new controller MyFilter                  # another controller and its test
```
]]

local function exists(path)
  local f = io.open(path, "r")
  if f then f:close() return true end
  return false
end

local function is_dir(path) return os.execute("test -d '" .. path:gsub("'", "'\\''") .. "'") == true end

local function mkdir(path) return os.execute("mkdir -p '" .. path:gsub("'", "'\\''") .. "'") == true end

local function write(path, text)
  local f, err = io.open(path, "w")
  if not f then return nil, "cannot write " .. tostring(err) end
  f:write(text)
  f:close()
  return true
end

--- Writes `files` ({path, text} in order) under `dir`: none when any exists already. Returns the paths written,
--- or nil and the reason.
local function write_all(dir, files)
  for _, f in ipairs(files) do
    if exists(dir .. "/" .. f[1]) then return nil, dir .. "/" .. f[1] .. " exists already: nothing was written" end
  end
  local written = {}
  for _, f in ipairs(files) do
    local path = dir .. "/" .. f[1]
    local sub = path:match("^(.*)/[^/]*$")
    if sub and not mkdir(sub) then return nil, "cannot make the folder " .. sub end
    local ok, err = write(path, f[2])
    if not ok then return nil, err end
    written[#written + 1] = path
  end
  return written
end

--- The files of controller `type` in package `package`.
function M.controller_files(package, type)
  local vars = { PACKAGE = package, TYPE = type }
  local stem = M.snake(type)
  return {
    { "src/" .. stem .. ".cpp", fill(CONTROLLER, vars) },
    { "tests/" .. stem .. "_test.cpp", fill(TEST, vars) },
  }
end

--- The files of a new package.
function M.package_files(package, type)
  local vars = { PACKAGE = package, TYPE = type }
  local files = {
    { "CMakeLists.txt", fill(CMAKE, vars) },
    { package .. ".dca", fill(SYSTEM, vars) },
    { "README.md", fill(README, vars) },
    { ".gitignore", "build/\n" },
  }
  for _, f in ipairs(M.controller_files(package, type)) do files[#files + 1] = f end
  return files
end

local function fail(msg)
  io.stderr:write("dca new: ", msg, "\n")
  return 1
end

local function new_package(o)
  local name, dir = o[2], o[3]
  if not name then return args.usage_error("dca new package: give the package's NAME", M.usage) end
  local err = M.package_name_error(name)
  if err then return fail(err) end
  local type = o.controller or M.camel(name)
  err = M.type_name_error(type)
  if err then return fail(err .. (o.controller and "" or " (give one with --controller TYPE)")) end
  dir = dir or name
  if exists(dir) or is_dir(dir) then return fail(dir .. " exists already: give a new folder") end
  local written, werr = write_all(dir, M.package_files(name, type))
  if not written then return fail(werr) end
  for _, p in ipairs(written) do print("wrote " .. p) end
  print(("package %s with the controller %s. Build and test it:\n" ..
         "  cmake -S %s -B %s/build -DCMAKE_PREFIX_PATH=<dca prefix> && cmake --build %s/build && ctest --test-dir %s/build")
        :format(name, type, dir, dir, dir, dir))
  return 0
end

--- The package name in DIR/CMakeLists.txt (its dca_add_controller_package), or nil and why not.
function M.package_of(dir)
  local f = io.open(dir .. "/CMakeLists.txt")
  if not f then return nil, "no CMakeLists.txt in " .. dir .. ": give the package's folder with --package DIR" end
  local text = f:read("a")
  f:close()
  local name = text:match("dca_add_controller_package%(%s*([%w_]+)")
  if not name then return nil, dir .. "/CMakeLists.txt has no dca_add_controller_package(NAME ...): not a package" end
  return name
end

local function new_controller(o)
  local type = o[2]
  if not type then return args.usage_error("dca new controller: give the controller's TYPE", M.usage) end
  if o[3] then return args.usage_error("dca new controller: unexpected argument '" .. o[3] .. "'", M.usage) end
  local err = M.type_name_error(type)
  if err then return fail(err) end
  local dir = o.package or "."
  local package, perr = M.package_of(dir)
  if not package then return fail(perr) end
  local written, werr = write_all(dir, M.controller_files(package, type))
  if not written then return fail(werr) end
  for _, p in ipairs(written) do print("wrote " .. p) end
  print(("controller %s in package %s: the next build compiles it and its test"):format(type, package))
  return 0
end

function M.main(argv)
  local o, err = args.parse(argv, "dca new", { ["--controller"] = "value", ["--package"] = "value" }, 3)
  if not o then return args.usage_error(err, M.usage) end
  if o[1] == "package" and not o.package then return new_package(o) end
  if o[1] == "controller" and not o.controller then return new_controller(o) end
  if o[1] == "package" or o[1] == "controller" then
    return args.usage_error("dca new " .. o[1] .. ": " .. (o.package and "--package" or "--controller") ..
                            " belongs to the other form", M.usage)
  end
  return args.usage_error(o[1] and ("dca new: unknown kind '" .. o[1] .. "' (package or controller)")
                          or "dca new: package or controller?", M.usage)
end

return M
