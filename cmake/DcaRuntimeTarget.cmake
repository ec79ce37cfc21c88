# dca_runtime: every target of the build except the GoogleTest executables (dca_add_gtest lists them in the global
# property DCA_GTEST_TARGETS): what the tests that are no GoogleTest case need (dca, its nodes, the packages, the
# test packages). scripts/test builds it first under the sanitizers, then runs those tests while the GoogleTest
# executables still compile (docs/build.md, "Scripts").
dca_property_below(${PROJECT_SOURCE_DIR} BUILDSYSTEM_TARGETS dca_all_targets)
get_property(dca_gtests GLOBAL PROPERTY DCA_GTEST_TARGETS)
add_custom_target(dca_runtime)
foreach(t IN LISTS dca_all_targets)
  get_target_property(type ${t} TYPE)
  get_target_property(excluded ${t} EXCLUDE_FROM_ALL)
  if(NOT type STREQUAL "INTERFACE_LIBRARY" AND NOT excluded AND NOT t IN_LIST dca_gtests)
    add_dependencies(dca_runtime ${t})
  endif()
endforeach()
if(TARGET dca_test_packages)  # (not in `all` by itself: the package tests depend on it)
  add_dependencies(dca_runtime dca_test_packages)
endif()

# dca_product: what dca runs with, nothing of tests/ (scripts/setup demo builds only this): the targets of the
# core's, the Lua side's, the controllers', the worlds' and the executables' folders.
add_custom_target(dca_product)
foreach(dir host bindings controllers sim worlds app packaging)
  dca_property_below(${PROJECT_SOURCE_DIR}/${dir} BUILDSYSTEM_TARGETS dca_dir_targets)
  foreach(t IN LISTS dca_dir_targets)
    get_target_property(type ${t} TYPE)
    get_target_property(excluded ${t} EXCLUDE_FROM_ALL)
    if(NOT type STREQUAL "INTERFACE_LIBRARY" AND NOT excluded)
      add_dependencies(dca_product ${t})
    endif()
  endforeach()
endforeach()

# dca_demo: what the door demo runs with (scripts/setup demo, scripts/demo): dca_product without the packages and
# libraries the door system does not load (the ROS 2 bridge, the joint controllers, the SDK's testing library)
# and the Debian package's files: a seventh of the product's compile time off a fresh machine's wait for its
# first simulated step.
add_custom_target(dca_demo)
get_property(dca_product_deps TARGET dca_product PROPERTY MANUALLY_ADDED_DEPENDENCIES)
foreach(t IN LISTS dca_product_deps)
  if(NOT t MATCHES "^(ros2|ros2_module|joint_control|joint_control_module|dca_testing|dca_deb_files)$")
    add_dependencies(dca_demo ${t})
  endif()
endforeach()
