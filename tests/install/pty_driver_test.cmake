# The driver contract (docs/drivers.md) proven out of tree: installs dca into a fresh prefix, builds
# examples/pty_driver elsewhere against it (nothing of the source or build tree on its compile lines), runs its
# tests (the line protocol on garbage, partial and overlong lines; the driver alone on a pty), then runs
# worlds/ur10/ur10_setpoint.dca, unchanged, with the installed dca on the simulated arm through the driver in
# wall-clock time (to DONE, over a noisy line whose bad lines are counted), on the mock hardware and on the Simbody
# world; and has a missing device and an arm that hangs up named in the run's ABORTED.
#   cmake -DBUILD_DIR=... -DSOURCE_DIR=... -P tests/install/pty_driver_test.cmake
# The waits are the processes' own ends (dca run's bounded start and stop; the arm ends with the run it started).
execute_process(COMMAND mktemp -d /tmp/dca_install_pty_driver_XXXXXX OUTPUT_VARIABLE WORK_DIR
                OUTPUT_STRIP_TRAILING_WHITESPACE)
include(${CMAKE_CURRENT_LIST_DIR}/run.cmake)

run("cmake --install" ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${WORK_DIR}/prefix)
file(COPY ${SOURCE_DIR}/examples/pty_driver/ DESTINATION ${WORK_DIR}/src)
build_outside("the pty driver" ${WORK_DIR}/src ${WORK_DIR}/build)
run("the pty driver's tests" ${CMAKE_CTEST_COMMAND} --test-dir ${WORK_DIR}/build --output-on-failure)
foreach(t pty_driver.protocol_test pty_driver.serial_arm_test)
  if(NOT out MATCHES "${t} [.]+ +Passed")
    fail("the example's test ${t} did not pass:\n${out}")
  endif()
endforeach()

set(dca ${CMAKE_COMMAND} -E env --unset=DCA_LUA_DIR --unset=DCA_MODELS_DIR "DCA_CONTROLLER_PATH=${WORK_DIR}/build"
        ${WORK_DIR}/prefix/bin/dca)
set(system ${SOURCE_DIR}/worlds/ur10/ur10_setpoint.dca)
set(urdf ${SOURCE_DIR}/worlds/ur10/ur10.urdf)
set(driver "pty_driver.SerialArm(\"arm\", \"@PTY@\")")

# expect(WHAT TEXT...): every TEXT (a regular expression) is in `out`.
function(expect what)
  foreach(text ${ARGN})
    if(NOT out MATCHES "${text}")
      fail("${what}: no '${text}' in its output:\n${out}")
    endif()
  endforeach()
endfunction()

# The same system on the driver (a noisy line: every 5th state line garbled, and an overlong line after it), the
# mock hardware and the Simbody world.
run("the system on the driver" ${WORK_DIR}/build/pty_arm --garble 5 -- ${dca} run ${system} --driver ${driver})
expect("the system on the driver" "driver: running" "main.wrist: done" "main: DONE"
       "driver: device.lines = [1-9][0-9]* [1-9][0-9]* [0-9]+ [1-9]")
run("the system on mock hardware" ${dca} run ${system} --sim mock:${urdf})
expect("the system on mock hardware" "main: DONE")
run("the system on the Simbody world" ${dca} run ${system} --sim ${urdf})
expect("the system on the Simbody world" "main: DONE")
# The UR10 pick and place of examples/ur10 (joint_control's JointTrajectory, the installed package), unchanged,
# on the driver too: its waypoints reached through the serial line, in wall-clock time.
run("the pick and place on the driver" ${WORK_DIR}/build/pty_arm -- ${dca} run ${SOURCE_DIR}/examples/ur10/pick_and_place.dca
    --driver ${driver})
expect("the pick and place on the driver" "main.pick: done" "main.place: done" "main: DONE")

# A device that is not there: the start fails naming it. An arm that hangs up: the run ends ABORTED naming it.
execute_process(COMMAND ${dca} run ${system} --driver "pty_driver.SerialArm(\"arm\", \"${WORK_DIR}/none\")"
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
set(out "${out}${err}")
if(NOT rc EQUAL 3)
  fail("a missing device: exit ${rc}, not 3 (a failed start):\n${out}")
endif()
expect("a missing device" "cannot open the device ${WORK_DIR}/none: No such file or directory")
execute_process(COMMAND ${WORK_DIR}/build/pty_arm --hangup-after 10 -- ${dca} run ${system} --driver ${driver}
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
set(out "${out}${err}")
if(NOT rc EQUAL 1)
  fail("an arm that hangs up: exit ${rc}, not 1 (ABORTED):\n${out}")
endif()
expect("an arm that hangs up" "main: ABORTED at main: the robot process was lost: the driver pty_driver.SerialArm"
       "sent no valid state line for 1 s [(]lines: 0 with a bad checksum, 0 garbled, 0 too long; the other side closed")
message(STATUS "the pty driver's system ended DONE on the driver, the mock hardware and the Simbody world; the UR10 pick and place on the driver")
file(REMOVE_RECURSE ${WORK_DIR})
