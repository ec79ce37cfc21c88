# dca_add_controller_package(NAME SOURCES src... [LIBS lib...] [OUTPUT_DIRECTORY dir] [INSTALL_DIR dir] [UNITY])
#
# A controller package (docs/packages.md): a shared library NAME.dca.so (the target NAME_module; the target NAME
# is its objects, where target_include_directories and the like go) of the controller
# types defined in SOURCES (each registered with DCA_REGISTER_CONTROLLER, controllers/registry.h), built against
# the dca SDK (the target dca::sdk) with dca's entry point, so that a .dca file's `use NAME;` loads it. dca finds
# it in $DCA_CONTROLLER_PATH, in <dca prefix>/lib/dca/controllers, or in a `packages/` folder beside the .dca
# file. `cmake --install` puts it in <prefix>/lib/dca/controllers (INSTALL_DIR to change that).
# Its files are compiled one by one, even where CMAKE_UNITY_BUILD is on: a package's files may each name their
# ports kIn, kOut in an anonymous namespace, as most packages do. UNITY: they may be joined in batches as the rest
# of a unity build is (no two of them define the same file-local name, as in dca's own packages).
# The library is linked against nothing of dca: the dca process that loads it provides those symbols.
#
# dca_add_controller_test(NAME PACKAGE pkg SOURCES src... [LIBS lib...])
#
# A unit test of a package's controllers, one at a time and with no running system (dca/testing/controller.h):
# an executable NAME of SOURCES, the package's own objects (so its types are in the registry) and dca::testing,
# plus LIBS (GTest::gtest_main for GoogleTest), registered with CTest as NAME.
#
# Used by the installed package config (dcaConfig.cmake) and by dca's own tree (the door package).
include_guard(GLOBAL)

# dca_package_properties(TARGET NAME): what makes a MODULE library the package NAME.
function(dca_package_properties target name)
  if(NOT name MATCHES "^[A-Za-z_][A-Za-z0-9_]*$")
    message(FATAL_ERROR "dca_add_controller_package: '${name}' is not a package name (letters, digits and '_')")
  endif()
  target_link_libraries(${target} PRIVATE dca::sdk)
  target_compile_definitions(${target} PRIVATE DCA_PACKAGE_NAME="${name}")
  target_compile_features(${target} PRIVATE cxx_std_20)
  # (UNITY_BUILD OFF: a package's files are compiled one by one, see above; dca_package_unity opts in)
  set_target_properties(${target} PROPERTIES PREFIX "" OUTPUT_NAME "${name}.dca" SUFFIX ".so"
                        POSITION_INDEPENDENT_CODE ON UNITY_BUILD OFF)
endfunction()

# dca_package_unity(TARGET): TARGET's sources joined in batches where CMAKE_UNITY_BUILD is on, as any other target's:
# for a package whose files define no file-local name twice.
function(dca_package_unity target)
  set_target_properties(${target} PROPERTIES UNITY_BUILD "${CMAKE_UNITY_BUILD}")
endfunction()

function(dca_add_controller_package name)
  cmake_parse_arguments(P "UNITY" "OUTPUT_DIRECTORY;INSTALL_DIR" "SOURCES;LIBS" ${ARGN})
  if(NOT P_SOURCES)
    message(FATAL_ERROR "dca_add_controller_package(${name}): no SOURCES")
  endif()
  # The target NAME is the package's objects, compiled once: `target_include_directories(NAME ...)`,
  # `target_link_libraries(NAME ...)` and the like apply to them as to any library, and reach both the package
  # (the MODULE NAME_module, built as NAME.dca.so) and each of its tests (dca_add_controller_test).
  add_library(${name} OBJECT ${P_SOURCES} ${DCA_PACKAGE_ENTRY_SOURCE})
  dca_package_properties(${name} ${name})
  if(P_UNITY)
    dca_package_unity(${name})
  endif()
  add_library(${name}_module MODULE)
  dca_package_properties(${name}_module ${name})
  target_link_libraries(${name}_module PRIVATE ${name})
  if(P_LIBS)
    target_link_libraries(${name} PUBLIC ${P_LIBS})
  endif()
  if(P_OUTPUT_DIRECTORY)
    set_target_properties(${name}_module PROPERTIES LIBRARY_OUTPUT_DIRECTORY ${P_OUTPUT_DIRECTORY})
  endif()
  if(NOT P_INSTALL_DIR)
    set(P_INSTALL_DIR lib/dca/controllers)
  endif()
  install(TARGETS ${name}_module LIBRARY DESTINATION ${P_INSTALL_DIR})
endfunction()

function(dca_add_controller_test name)
  cmake_parse_arguments(T "" "PACKAGE" "SOURCES;LIBS" ${ARGN})
  if(NOT T_SOURCES OR NOT T_PACKAGE)
    message(FATAL_ERROR "dca_add_controller_test(${name}): give PACKAGE and SOURCES")
  endif()
  if(NOT TARGET ${T_PACKAGE}_module)
    message(FATAL_ERROR "dca_add_controller_test(${name}): no package '${T_PACKAGE}' (dca_add_controller_package first)")
  endif()
  add_executable(${name} ${T_SOURCES})
  target_compile_features(${name} PRIVATE cxx_std_20)
  target_link_libraries(${name} PRIVATE ${T_PACKAGE} dca::testing ${T_LIBS})
  add_test(NAME ${name} COMMAND ${name})
endfunction()
