# The door package rebuilt outside the tree against an installed dca only (docs/packages.md, "The SDK"): installs
# dca into a fresh prefix and removes the door package it installed, copies the package's sources (controllers/door,
# controllers/math, controllers/robot/model.*) with tests/install/door/CMakeLists.txt elsewhere, builds them against
# that prefix (nothing of the source or build tree on its compile lines), then runs the door system in simulated
# time with the installed dca and that package: its trace must be the build tree's, byte for byte.
#   cmake -DBUILD_DIR=... -DSOURCE_DIR=... -P door_package_test.cmake
execute_process(COMMAND mktemp -d /tmp/dca_install_door_XXXXXX OUTPUT_VARIABLE WORK_DIR OUTPUT_STRIP_TRAILING_WHITESPACE)
include(${CMAKE_CURRENT_LIST_DIR}/run.cmake)

run("cmake --install" ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${WORK_DIR}/prefix)
file(REMOVE ${WORK_DIR}/prefix/lib/dca/controllers/door.dca.so)  # only the one built here can be found
foreach(d door math)
  file(COPY ${SOURCE_DIR}/controllers/${d} DESTINATION ${WORK_DIR}/src)
endforeach()
file(COPY ${SOURCE_DIR}/controllers/robot/model.h ${SOURCE_DIR}/controllers/robot/model.cpp DESTINATION ${WORK_DIR}/src/robot)
file(COPY ${SOURCE_DIR}/tests/install/door/CMakeLists.txt DESTINATION ${WORK_DIR}/src)

build_outside("the door package" ${WORK_DIR}/src ${WORK_DIR}/build)

set(env ${CMAKE_COMMAND} -E env --unset=DCA_LUA_DIR --unset=DCA_MODELS_DIR)
set(system ${SOURCE_DIR}/worlds/door/systems/door_open.dca)
run("dca types --package door" ${env} DCA_CONTROLLER_PATH=${WORK_DIR}/build ${WORK_DIR}/prefix/bin/dca types
    --package door)
string(FIND "${out}" "PressHandle(host, speed=0.03, force=30, travel=0.02, compliance=0.002, period=0.01)    (package door)" at)
if(at EQUAL -1)
  fail("dca types --package door does not list PressHandle from the package built here:\n${out}")
endif()
run("the door system on the installed dca" ${env} DCA_CONTROLLER_PATH=${WORK_DIR}/build ${WORK_DIR}/prefix/bin/dca
    run ${system} --sim door --seed 0 --trace ${WORK_DIR}/installed.trace)
run("the door system on the build tree" ${BUILD_DIR}/bin/dca run ${system} --sim door --seed 0
    --trace ${WORK_DIR}/tree.trace)
run("dca trace diff" ${BUILD_DIR}/bin/dca trace diff ${WORK_DIR}/tree.trace ${WORK_DIR}/installed.trace)
string(FIND "${out}" "identical" at)
if(at EQUAL -1)
  fail("the door run with the package built here differs from the build tree's:\n${out}")
endif()
message(STATUS "the door package built against the installed dca runs the door system identically")
file(REMOVE_RECURSE ${WORK_DIR})
