# fail(MESSAGE): fails the test, first removing its folder WORK_DIR (made in /tmp by the test that includes this):
# a failed run leaves nothing behind either; MESSAGE carries the output that shows why.
function(fail msg)
  if(WORK_DIR)
    file(REMOVE_RECURSE ${WORK_DIR})
  endif()
  message(FATAL_ERROR "${msg}")
endfunction()

# run(WHAT COMMAND...): runs a command, failing the test with its output when it fails; its output in `out`.
function(run what)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    fail("${what} failed (${rc}):\n${out}${err}")
  endif()
  set(out "${out}${err}" PARENT_SCOPE)
endfunction()

# build_outside(WHAT SRC BUILD): configures and builds the project SRC in BUILD against the dca installed in
# ${WORK_DIR}/prefix, and fails when its build refers to the source tree or the build tree of dca.
function(build_outside what src build)
  run("configuring ${what}" ${CMAKE_COMMAND} -S ${src} -B ${build} -G Ninja -DCMAKE_BUILD_TYPE=Release
      -DCMAKE_PREFIX_PATH=${WORK_DIR}/prefix)
  run("building ${what}" ${CMAKE_COMMAND} --build ${build})
  file(READ ${build}/build.ninja ninja)
  foreach(tree ${SOURCE_DIR} ${BUILD_DIR})
    string(FIND "${ninja}" "${tree}" at)
    if(NOT at EQUAL -1)
      fail("${what}'s build refers to ${tree}: it must use the installed dca only")
    endif()
  endforeach()
endfunction()
