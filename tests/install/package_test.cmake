# A controller package built outside the tree against an installed dca only (README.md, "Write your own
# controller"): installs dca into a fresh prefix, copies examples/controller_package elsewhere, configures and
# builds it against that prefix (nothing of the source or build tree on its compile lines), runs its tests (unit
# tests on the installed dca::testing, and small systems) and
# its system with the installed `dca run` to DONE, and has the installed `dca check` report a port typo in the
# system at file:line:col from the package's manifest.
#   cmake -DBUILD_DIR=... -DSOURCE_DIR=... -P tests/install/package_test.cmake
# It works in a fresh directory outside both trees (so that no path into them can hide in its build), removed
# at the end when it passed. Then it does the same with a package written by `dca new`.
execute_process(COMMAND mktemp -d /tmp/dca_install_package_XXXXXX OUTPUT_VARIABLE WORK_DIR
                OUTPUT_STRIP_TRAILING_WHITESPACE)
include(${CMAKE_CURRENT_LIST_DIR}/run.cmake)

string(TIMESTAMP t0 "%s")
run("cmake --install" ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${WORK_DIR}/prefix)
file(COPY ${SOURCE_DIR}/examples/controller_package/ DESTINATION ${WORK_DIR}/mylab)
set(dca ${CMAKE_COMMAND} -E env --unset=DCA_LUA_DIR --unset=DCA_MODELS_DIR "DCA_CONTROLLER_PATH=${WORK_DIR}/build"
        ${WORK_DIR}/prefix/bin/dca)

string(TIMESTAMP t1 "%s")
build_outside("the example" ${WORK_DIR}/mylab ${WORK_DIR}/build)
string(TIMESTAMP t2 "%s")
if(NOT EXISTS ${WORK_DIR}/build/mylab.dca.so)
  fail("no ${WORK_DIR}/build/mylab.dca.so")
endif()

run("the example's tests" ${CMAKE_CTEST_COMMAND} --test-dir ${WORK_DIR}/build --output-on-failure)
# Its unit tests (the controllers alone on the installed dca::testing) ran among them.
foreach(t mylab.pid_test mylab.low_pass_test mylab.pid mylab.low_pass)
  if(NOT out MATCHES "${t} [.]+ +Passed")
    fail("the example's test ${t} did not pass:\n${out}")
  endif()
endforeach()
run("dca types --package mylab" ${dca} types --package mylab)
foreach(want "Pid(host, setpoint, kp, ki=0, kd=0, period=0.01)    (package mylab)" "LowPass(host, tau")
  string(FIND "${out}" "${want}" at)
  if(at EQUAL -1)
    fail("dca types --package mylab does not list ${want}:\n${out}")
  endif()
endforeach()
run("dca run lab.dca" ${dca} run ${WORK_DIR}/mylab/lab.dca)
string(FIND "${out}" "main: DONE" at)
if(at EQUAL -1)
  fail("dca run lab.dca did not end DONE:\n${out}")
endif()

# A port typo: Measured -> Measure, at its line and column, with the manifest's inputs.
file(READ ${WORK_DIR}/mylab/lab.dca text)
string(REPLACE "pid, Measured;" "pid, Measure;" text "${text}")
file(WRITE ${WORK_DIR}/mylab/typo.dca "${text}")
execute_process(COMMAND ${dca} check ${WORK_DIR}/mylab/typo.dca RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
string(REGEX MATCH "typo.dca:([0-9]+):([0-9]+): [^\n]*Measure[^\n]*" line "${err}")
if(rc EQUAL 0 OR NOT line OR NOT err MATCHES "Measured")
  fail("dca check did not report the typo at file:line:col with the manifest's input (${rc}):\n${out}${err}")
endif()
# `dca new package` writes a package that builds and passes its tests (its controller's unit test and its system
# to DONE), and `dca new controller` adds a controller whose test the next build runs.
run("dca new package" ${dca} new package gen ${WORK_DIR}/gen)
run("dca new controller" ${dca} new controller Second --package ${WORK_DIR}/gen)
build_outside("the package of dca new" ${WORK_DIR}/gen ${WORK_DIR}/gen/build)
run("the tests of dca new's package" ${CMAKE_CTEST_COMMAND} --test-dir ${WORK_DIR}/gen/build --output-on-failure)
foreach(t gen.gen_test gen.second_test gen.system)
  if(NOT out MATCHES "${t} [.]+ +Passed")
    fail("the test ${t} of dca new's package did not pass:\n${out}")
  endif()
endforeach()
string(TIMESTAMP t3 "%s")
math(EXPR install "${t1} - ${t0}")
math(EXPR build "${t2} - ${t1}")
math(EXPR rest "${t3} - ${t2}")
message(STATUS "${line}")
message(STATUS "install ${install} s, configure + build of the example ${build} s, its tests + run + check ${rest} s")
file(REMOVE_RECURSE ${WORK_DIR})
