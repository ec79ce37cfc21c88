# The Debian package (docs/deploy.md, "The package"): CPack packs the build tree's install as it is (the test
# reuses the build: `cpack` installs it into a staging folder and runs dpkg-deb, nothing is compiled), then:
# its control fields (dpkg-deb -f), its file list (dpkg-deb -c: binaries, Lua, models, worlds, the SDK and its CMake
# package, the door package, the unit, /etc/dca, the docs; nothing of the build or source tree, nothing under
# /usr/local), its conffiles and maintainer scripts, `systemd-analyze verify` on its unit, lintian (no error or
# warning), and the dca it holds, unpacked: `dca --version` and `dca types` find their files in it.
#   cmake -DBUILD_DIR=... -DSOURCE_DIR=... -P tests/packaging/deb_test.cmake
if(NOT DEFINED ENV{TMPDIR} OR "$ENV{TMPDIR}" STREQUAL "")
  set(ENV{TMPDIR} /tmp)
endif()
execute_process(COMMAND mktemp -d $ENV{TMPDIR}/dca_deb_XXXXXX OUTPUT_VARIABLE WORK_DIR OUTPUT_STRIP_TRAILING_WHITESPACE)
include(${SOURCE_DIR}/tests/install/run.cmake)

# contains(WHAT TEXT NEEDLE...): fails unless every NEEDLE is in TEXT.
function(contains what text)
  foreach(needle ${ARGN})
    string(FIND "${text}" "${needle}" at)
    if(at EQUAL -1)
      fail("${what} lacks '${needle}':\n${text}")
    endif()
  endforeach()
endfunction()

string(TIMESTAMP t0 "%s")
run("cpack" cpack --config ${BUILD_DIR}/CPackConfig.cmake -B ${WORK_DIR})
file(GLOB deb ${WORK_DIR}/dca_*.deb)
if(NOT deb)
  fail("cpack made no dca_*.deb in ${WORK_DIR}:\n${out}")
endif()
string(TIMESTAMP t1 "%s")

# Control fields.
run("dpkg-deb -f" dpkg-deb -f ${deb})
set(fields "${out}")
file(STRINGS ${SOURCE_DIR}/CMakeLists.txt project REGEX "^project\\(dca VERSION")
string(REGEX MATCH "VERSION ([0-9.]+)" _ "${project}")
set(version ${CMAKE_MATCH_1})
contains("the control fields" "${fields}" "Package: dca\n" "Version: ${version}\n" "Maintainer: dca maintainers <"
         "Section: science" "Priority: optional" "Description: distributed control architecture for robots")
string(REGEX MATCH "\nDepends: [^\n]*" depends "${fields}")
# dpkg-shlibdeps found the shared libraries' packages; lpeg (loaded by Lua) and adduser (postinst) are named
contains("Depends" "${depends}" "liblua5.4-0" "libsimbody" "libsqlite3-0" "libssl3" "libedit2" "lua-lpeg" "adduser")

# Files.
run("dpkg-deb -c" dpkg-deb -c ${deb})
set(files "${out}")
contains("the package's files" "${files}" " ./usr/bin/dca\n" " ./usr/bin/dca-node\n" " ./usr/bin/dca-supervise\n"
         " ./usr/share/dca/lua/dca/supervisor/init.lua\n" " ./usr/share/dca/lua/dca/lang/parser.lua\n"
         " ./usr/share/dca/models/" ".urdf\n" " ./usr/share/dca/worlds/door/world.lua\n"
         " ./usr/include/dca/controller.h\n" " ./usr/include/dca/version.h\n"
         " ./usr/lib/cmake/dca/dcaConfig.cmake\n" " ./usr/lib/cmake/dca/DcaPackage.cmake\n"
         " ./usr/lib/libdca_testing.a\n" " ./usr/lib/dca/controllers/door.dca.so\n"
         " ./lib/systemd/system/dca-daemon.service\n" " ./etc/dca/hosts\n" " ./etc/default/dca-daemon\n"
         " ./usr/share/doc/dca/copyright\n" " ./usr/share/doc/dca/changelog.gz\n"
         " ./usr/share/man/man1/dca.1.gz\n" " ./usr/share/man/man1/dca-node.1.gz\n"
         " ./usr/share/bash-completion/completions/dca\n")
# the monitor's page and every module of its 3D view that its server serves (VENDOR in lua/dca/monitor/server.lua)
file(READ ${SOURCE_DIR}/lua/dca/monitor/server.lua server)
string(REGEX MATCH "local VENDOR = {[^}]*}" vendor "${server}")
string(REGEX MATCHALL "\"[^\"]+\"" vendor "${vendor}")
if(NOT vendor)
  fail("no VENDOR list found in lua/dca/monitor/server.lua")
endif()
set(page " ./usr/share/dca/lua/dca/monitor/page/")
contains("the package's files" "${files}" "${page}index.html\n" "${page}monitor.js\n" "${page}robot3d.js\n"
         "${page}3d/node_modules/three/LICENSE\n")
foreach(v ${vendor})
  string(REPLACE "\"" "" v "${v}")
  contains("the package's files (VENDOR of lua/dca/monitor/server.lua)" "${files}" "${page}3d/node_modules/${v}\n")
endforeach()
foreach(bad "./usr/local" "${BUILD_DIR}" "${SOURCE_DIR}" "./etc/dca/key" "fuzz_" "_test\n")
  string(FIND "${files}" "${bad}" at)
  if(NOT at EQUAL -1)
    fail("the package holds '${bad}':\n${files}")
  endif()
endforeach()

# Conffiles and maintainer scripts.
run("dpkg-deb -e" dpkg-deb -e ${deb} ${WORK_DIR}/control)
file(READ ${WORK_DIR}/control/conffiles conffiles)
if(NOT conffiles STREQUAL "/etc/dca/hosts\n/etc/default/dca-daemon\n")
  fail("conffiles: '${conffiles}'")
endif()
foreach(script postinst prerm postrm)
  run("sh -n ${script}" sh -n ${WORK_DIR}/control/${script})
endforeach()
file(READ ${WORK_DIR}/control/postinst postinst)
contains("postinst" "${postinst}" "adduser --system" "/etc/dca/key" "chmod 0600 /etc/dca/key" "deb-systemd-helper")

# The unit, in the package's unpacked tree (its ExecStart is found there).
run("dpkg-deb -x" dpkg-deb -x ${deb} ${WORK_DIR}/root)
file(READ ${WORK_DIR}/root/lib/systemd/system/dca-daemon.service unit)
contains("the unit" "${unit}" "Type=notify" "WatchdogSec=" "NoNewPrivileges=yes" "ProtectSystem=strict"
         "ExecStart=/usr/bin/dca daemon --key /etc/dca/key")
# systemd-analyze verify: every key known, every value valid; it wants ExecStart's program where the unit says, so
# it reads a copy that names the unpacked one
find_program(analyze systemd-analyze)
if(NOT analyze)
  fail("systemd-analyze is not installed (scripts/setup installs systemd)")
endif()
string(REPLACE "ExecStart=/usr/bin/dca " "ExecStart=${WORK_DIR}/root/usr/bin/dca " copy "${unit}")
file(WRITE ${WORK_DIR}/verify/dca-daemon.service "${copy}")
run("systemd-analyze verify" ${analyze} verify ${WORK_DIR}/verify/dca-daemon.service)
if(NOT out STREQUAL "")
  fail("systemd-analyze verify has something to say about the unit:\n${out}")
endif()
string(TIMESTAMP t2 "%s")

# lintian: no error, no warning (the package carries no overrides).
find_program(lintian lintian)
if(NOT lintian)
  fail("lintian is not installed (scripts/setup installs it)")
endif()
# (its own temporary files in the work directory: it leaves some behind)
execute_process(COMMAND ${CMAKE_COMMAND} -E env TMPDIR=${WORK_DIR} ${lintian} --fail-on error,warning ${deb}
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0 OR out MATCHES "(^|\n)[EW]: ")
  fail("lintian (${rc}):\n${out}${err}")
endif()
string(TIMESTAMP t3 "%s")

# The dca it holds, as unpacked: its Lua modules, worlds and door package are found beside it.
set(dca ${CMAKE_COMMAND} -E env --unset=DCA_LUA_DIR --unset=DCA_MODELS_DIR --unset=DCA_WORLDS_DIR
        --unset=DCA_CONTROLLER_PATH ${WORK_DIR}/root/usr/bin/dca)
run("dca --version" ${dca} --version)
contains("dca --version" "${out}" "dca ${version}")
run("dca types" ${dca} types)
contains("dca types" "${out}" "Timer(" "(package door)")

math(EXPR pack "${t1} - ${t0}")
math(EXPR checks "${t2} - ${t1}")
math(EXPR lint "${t3} - ${t2}")
message(STATUS "cpack ${pack} s, dpkg-deb and unit checks ${checks} s, lintian ${lint} s")
file(REMOVE_RECURSE ${WORK_DIR})
