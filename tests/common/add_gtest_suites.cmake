# Run after a test executable is built (mm_gtest_suites, GtestSuites.cmake):
# lists its tests and writes CTEST_FILE, one add_test a GoogleTest suite.
#   cmake -D TEST_EXECUTABLE=... -D TEST_WORKING_DIR=... -D TEST_PROPERTIES=...
#         -D TEST_DISCOVERY_TIMEOUT=... -D CTEST_FILE=... -P add_gtest_suites.cmake
execute_process(
  COMMAND "${TEST_EXECUTABLE}" --gtest_list_tests
  WORKING_DIRECTORY "${TEST_WORKING_DIR}"
  TIMEOUT ${TEST_DISCOVERY_TIMEOUT}
  OUTPUT_VARIABLE listing
  ERROR_VARIABLE errors
  RESULT_VARIABLE result)
if(NOT result EQUAL 0)
  message(FATAL_ERROR "listing the tests of ${TEST_EXECUTABLE} failed (${result}):\n${listing}${errors}")
endif()

string(REPLACE "\n" ";" lines "${listing}")
set(script "")
set(suites 0)
foreach(line IN LISTS lines)
  # A suite's line is its name and a dot, and a comment for a typed suite
  # ("Suite.  # TypeParam = int"); its tests' lines are indented.
  if(line MATCHES "^([A-Za-z_][A-Za-z0-9_/]*)\\.( .*)?$")
    set(suite "${CMAKE_MATCH_1}")
    string(APPEND script "add_test([==[${suite}]==] [==[${TEST_EXECUTABLE}]==] [==[--gtest_filter=${suite}.*]==])\n"
                         "set_tests_properties([==[${suite}]==] PROPERTIES WORKING_DIRECTORY [==[${TEST_WORKING_DIR}]==]")
    foreach(word IN LISTS TEST_PROPERTIES)
      string(APPEND script " [==[${word}]==]")
    endforeach()
    string(APPEND script ")\n")
    math(EXPR suites "${suites} + 1")
  endif()
endforeach()
if(suites EQUAL 0)
  message(FATAL_ERROR "${TEST_EXECUTABLE} lists no test suite:\n${listing}")
endif()
# Written whole, then renamed: ctest never reads half a file.
file(WRITE "${CTEST_FILE}.new" "${script}")
file(RENAME "${CTEST_FILE}.new" "${CTEST_FILE}")
