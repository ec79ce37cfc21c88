# Compiler flags as INTERFACE targets: link them, never set global flags.

# dca::warnings: the warning set every dca target builds with.
add_library(dca_warnings INTERFACE)
target_compile_options(dca_warnings INTERFACE
  -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor -Wold-style-cast -Wcast-align
  -Wunused -Woverloaded-virtual -Wnull-dereference -Wdouble-promotion -Wformat=2 -Wimplicit-fallthrough
  $<$<BOOL:${DCA_WERROR}>:-Werror>
  $<$<AND:$<BOOL:${CMAKE_UNITY_BUILD}>,$<CXX_COMPILER_ID:GNU>>:-Wno-subobject-linkage>)
add_library(dca::warnings ALIAS dca_warnings)

# dca::sanitizers: ASan + UBSan when DCA_SANITIZE is on, nothing otherwise.
add_library(dca_sanitizers INTERFACE)
if(DCA_SANITIZE)
  # -fno-sanitize=vptr: UBSan checks a vptr's memory by writing it to a pipe; a process at its descriptor limit
  # (tests/host/bounds_test.cpp puts a daemon there on purpose) cannot open one, and UBSan then reports every
  # virtual call (boost::system::error_category::message) as a call on an invalid object and aborts. Its
  # suppressions cannot help: they are read from a file, which it cannot open either.
  target_compile_options(dca_sanitizers INTERFACE
    -fsanitize=address,undefined -fno-sanitize=vptr -fno-sanitize-recover=all -fno-omit-frame-pointer)
  target_link_options(dca_sanitizers INTERFACE -fsanitize=address,undefined -fno-sanitize=vptr)
  target_compile_definitions(dca_sanitizers INTERFACE DCA_SANITIZE=1)
  # GCC 12's -Wmaybe-uninitialized gives false positives on std::variant copies once ASan instruments the code
  # (tests/bindings/lua_value_test.cpp), and at -Og (scripts/setup) -Wmismatched-new-delete one on msgpack's zone,
  # whose class-specific operator new and delete are malloc and free; the optimised build keeps both warnings.
  target_compile_options(dca_sanitizers INTERFACE
    $<$<CXX_COMPILER_ID:GNU>:-Wno-maybe-uninitialized -Wno-mismatched-new-delete>)
endif()
add_library(dca::sanitizers ALIAS dca_sanitizers)

# dca::simbody: Simbody with the flags its Debian build needs.
# Debian built Simbody without NDEBUG and a class in its headers changes layout with NDEBUG, so every file
# that includes Simbody must be compiled with -UNDEBUG or Release builds crash in realizeTopology().
# Simbody 3.7's headers do not compile as C++20: targets that use this must set CXX_STANDARD 17.
add_library(dca_simbody INTERFACE)
target_link_libraries(dca_simbody INTERFACE SimTKsimbody SimTKmath SimTKcommon)
# Under ASan, GCC 12 reports -Warray-bounds and -Wstringop-overflow false positives inside Simbody's headers
# (instantiated in our files, so SYSTEM includes do not hide them).
target_compile_options(dca_simbody INTERFACE -UNDEBUG
  $<$<BOOL:${DCA_SANITIZE}>:-Wno-array-bounds -Wno-stringop-overflow>)
add_library(dca::simbody ALIAS dca_simbody)

# dca_add_library(name folder-alias SOURCES...): one library per folder, with its alias and flags.
function(dca_add_library name alias)
  add_library(${name} ${ARGN})
  add_library(${alias} ALIAS ${name})
  target_link_libraries(${name} PRIVATE dca::warnings PUBLIC dca::sanitizers)
  target_include_directories(${name} PUBLIC $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}>
                                             $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}/sdk/include>)
endfunction()

# dca_exports_sdk(target): the executable exports dca's own symbols (namespace dca, cmake/dca_exports.list) to
# the controller packages it loads (controllers/packages.h), which link against nothing of dca.
function(dca_exports_sdk target)
  target_link_options(${target} PRIVATE "LINKER:--dynamic-list=${PROJECT_SOURCE_DIR}/cmake/dca_exports.list")
  set_property(TARGET ${target} APPEND PROPERTY LINK_DEPENDS ${PROJECT_SOURCE_DIR}/cmake/dca_exports.list)
endfunction()
