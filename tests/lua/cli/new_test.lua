-- `dca new package` and `dca new controller` as a user runs them (the output's build, tests and run:
-- tests/install/package_test.cmake, against an installed dca).
local T = require "dca.testing"
local new = require "dca.cli.new"
local suite = T.suite("new")

suite:case("a_package_has_its_build_controller_test_and_system", function()
  local dir = T.tmpdir() .. "/door_tools"
  T.dca("new package door_tools " .. dir, 0, "wrote " .. dir .. "/CMakeLists.txt",
    "package door_tools with the controller DoorTools")
  local cmake = T.read(dir .. "/CMakeLists.txt")
  T.contains(cmake, "project(door_tools LANGUAGES CXX)")
  T.contains(cmake, "dca_add_controller_package(door_tools SOURCES ${sources})")
  T.contains(cmake, "dca_add_controller_test(door_tools.${n} PACKAGE door_tools")
  local cpp = T.read(dir .. "/src/door_tools.cpp")
  T.contains(cpp, "class DoorTools final : public dca::PeriodicController {")
  T.contains(cpp, "namespace door_tools {")
  T.contains(cpp, 'DCA_REGISTER_CONTROLLER(DoorTools);')
  T.contains(T.read(dir .. "/tests/door_tools_test.cpp"), 'ControllerUnderTest c("DoorTools", {"1.0", "2.0"});')
  local system = dir .. "/door_tools.dca"
  T.contains(T.read(system), "use door_tools;")
  T.ok(T.exists(dir .. "/README.md") and T.exists(dir .. "/.gitignore"))
  -- The system is a correct .dca (its type comes from the package, which is not built here).
  T.dca("check --no-registry " .. system, 0)
end)

suite:case("a_controller_is_added_to_the_package_in_the_folder", function()
  local dir = T.tmpdir() .. "/lab"
  T.dca("new package lab " .. dir .. " --controller Pid", 0, "with the controller Pid")
  T.dca("new controller MyFilter --package " .. dir, 0, "wrote " .. dir .. "/src/my_filter.cpp",
    "wrote " .. dir .. "/tests/my_filter_test.cpp", "controller MyFilter in package lab")
  T.contains(T.read(dir .. "/src/my_filter.cpp"), "namespace lab {")
  T.dca("new controller MyFilter --package " .. dir, 1, dir .. "/src/my_filter.cpp exists already: nothing was written")
  T.dca("new controller Pid2 --package " .. T.tmpdir(), 1, "no CMakeLists.txt in ")
end)

suite:case("nothing_existing_is_overwritten", function()
  local dir = T.tmpdir()
  T.dca("new package lab " .. dir, 1, dir .. " exists already: give a new folder")
end)

suite:case("bad_names_are_refused_with_the_rule", function()
  local dir = T.tmpdir()
  T.dca("new package 9lab " .. dir .. "/x", 1, "'9lab' is not a package name")
  T.dca("new package class " .. dir .. "/x", 1, "'class' is a C++ keyword")
  T.dca("new package lab " .. dir .. "/x --controller pid", 1, "'pid' is not a controller type name")
  T.dca("new package _ " .. dir .. "/x", 1, "(give one with --controller TYPE)")
  T.ok(not T.exists(dir .. "/x/CMakeLists.txt"), "nothing is written for a bad name")
end)

suite:case("usage_errors_exit_2", function()
  T.dca("new", 2, "usage: dca new package NAME")
  T.dca("new widget x", 2, "unknown kind 'widget'")
  T.dca("new package", 2, "give the package's NAME")
  T.dca("new controller", 2, "give the controller's TYPE")
  T.dca("new controller A B", 2, "unexpected argument 'B'")
end)

suite:case("names_convert_between_cases", function()
  T.eq(new.camel("door_tools"), "DoorTools")
  T.eq(new.camel("mylab"), "Mylab")
  T.eq(new.snake("DoorTools"), "door_tools")
  T.eq(new.snake("PID2Filter"), "pid2_filter")
  T.eq(new.snake("Pid"), "pid")
end)

return suite:run(...)
