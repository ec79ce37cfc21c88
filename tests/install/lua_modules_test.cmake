# Installs the build into a fresh prefix, hides the source tree's lua/ from the installed dca (by running it
# with a copy of the prefix moved elsewhere) and checks that `require "dca.testing"` resolves inside the prefix.
file(REMOVE_RECURSE ${WORK_DIR})
execute_process(COMMAND ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${WORK_DIR}/prefix
                RESULT_VARIABLE rc OUTPUT_QUIET)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "cmake --install failed: ${rc}")
endif()
file(RENAME ${WORK_DIR}/prefix ${WORK_DIR}/moved)
file(WRITE ${WORK_DIR}/probe.lua [[
local t = require "dca.testing"
assert(type(t.suite) == "function")
print(package.searchpath("dca.testing", package.path))
]])
execute_process(COMMAND ${CMAKE_COMMAND} -E env --unset=DCA_LUA_DIR ${WORK_DIR}/moved/bin/dca lua ${WORK_DIR}/probe.lua
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "installed dca failed (${rc}): ${out}${err}")
endif()
string(FIND "${out}" "${WORK_DIR}/moved/share/dca/lua/dca/testing.lua" at)
if(at EQUAL -1)
  message(FATAL_ERROR "installed dca loaded dca.testing from outside its prefix: ${out}")
endif()
message(STATUS "installed dca loads ${out}")
