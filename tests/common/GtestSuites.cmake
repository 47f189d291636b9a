# mm_gtest_suites(TARGET [DISCOVERY_TIMEOUT SECONDS] [PROPERTIES NAME VALUE ...])
#
# One ctest test for each GoogleTest suite of the test executable TARGET,
# named as the suite and running its tests in one process
# (--gtest_filter=Suite.*), with the given test properties. Why not one a
# test, as gtest_discover_tests registers them: a suite's tests share what
# its fixture sets up once (the shipped model loaded, a server started),
# and a process of its own for every test paid that again, with LibTorch's
# start, for each of them: measured on the idle 2 cores, the 20 RestApi
# tests took 25.0 s one process a test against 5.8 s as one suite, the 16
# GrpcApiTest tests 25.1 s against 7.4, the 10 PaperUnits tests 6.8 s
# against 2.8. One test is still run alone with the executable's
# --gtest_filter (tests/README.md).
#
# As gtest_discover_tests does, the suites are listed after each build of
# the target (its --gtest_list_tests, by add_gtest_suites.cmake), so that a
# new test or suite needs no new configure. A ';' in a property's value
# splits it, as with gtest_discover_tests.
function(mm_gtest_suites target)
  cmake_parse_arguments(PARSE_ARGV 1 arg "" "DISCOVERY_TIMEOUT" "PROPERTIES")
  if(NOT arg_DISCOVERY_TIMEOUT)
    set(arg_DISCOVERY_TIMEOUT 60)
  endif()
  set(suites_file "${CMAKE_CURRENT_BINARY_DIR}/${target}_suites.cmake")
  add_custom_command(
    TARGET ${target} POST_BUILD
    BYPRODUCTS "${suites_file}"
    COMMAND "${CMAKE_COMMAND}"
            -D "TEST_EXECUTABLE=$<TARGET_FILE:${target}>"
            -D "TEST_WORKING_DIR=${CMAKE_CURRENT_BINARY_DIR}"
            -D "TEST_PROPERTIES=${arg_PROPERTIES}"
            -D "TEST_DISCOVERY_TIMEOUT=${arg_DISCOVERY_TIMEOUT}"
            -D "CTEST_FILE=${suites_file}"
            -P "${CMAKE_CURRENT_FUNCTION_LIST_DIR}/add_gtest_suites.cmake"
    VERBATIM)
  # ctest reads the suites from the file the build wrote; before the first
  # build one placeholder test fails, saying so.
  set(include_file "${CMAKE_CURRENT_BINARY_DIR}/${target}_suites_include.cmake")
  file(WRITE "${include_file}"
       "if(EXISTS \"${suites_file}\")\n"
       "  include(\"${suites_file}\")\n"
       "else()\n"
       "  add_test(${target}_NOT_BUILT ${target}_NOT_BUILT)\n"
       "endif()\n")
  set_property(DIRECTORY APPEND PROPERTY TEST_INCLUDE_FILES "${include_file}")
endfunction()
