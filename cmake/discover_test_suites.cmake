# Run as `cmake -P` after a test executable is built (test_suites.cmake): lists its tests
# and writes CTEST_FILE, one add_test a suite. Inputs: TEST_EXECUTABLE, TEST_WORKING_DIR,
# TEST_PROPERTIES (name;value;... for set_tests_properties), DISCOVERY_TIMEOUT, CTEST_FILE,
# COST_TABLE (lines `Suite seconds`: each suite's COST, 0 for a suite it does not name),
# SERIAL_SUITES (suites ctest runs alone: RUN_SERIAL).
execute_process(
  COMMAND "${TEST_EXECUTABLE}" --gtest_list_tests
  WORKING_DIRECTORY "${TEST_WORKING_DIR}"
  TIMEOUT ${DISCOVERY_TIMEOUT}
  OUTPUT_VARIABLE listing
  ERROR_VARIABLE listing_errors
  RESULT_VARIABLE status)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "listing the tests of ${TEST_EXECUTABLE} failed (${status}):\n"
                      "${listing}\n${listing_errors}")
endif()

# A suite is a line `Suite.` (or `Prefix/Suite.  # TypeParam = ...` for typed and
# parameterised suites) at the start of a line; its tests are the indented lines below it.
# Anything else a main prints before the listing is not a suite.
string(REPLACE ";" "\\;" listing "${listing}")
string(REPLACE "\n" ";" lines "${listing}")
set(suites "")
foreach(line IN LISTS lines)
  if(line MATCHES "^([A-Za-z_][A-Za-z0-9_/]*)\\.( |$)")
    list(APPEND suites "${CMAKE_MATCH_1}")
  endif()
endforeach()
if(NOT suites)
  message(FATAL_ERROR "${TEST_EXECUTABLE} lists no test suites:\n${listing}")
endif()

file(STRINGS "${COST_TABLE}" cost_lines REGEX "^[^#]")
set(script "")
foreach(suite IN LISTS suites)
  set(cost 0)
  foreach(cost_line IN LISTS cost_lines)
    if(cost_line MATCHES "^([^ ]+) ([0-9.]+)$" AND CMAKE_MATCH_1 STREQUAL suite)
      set(cost ${CMAKE_MATCH_2})
    endif()
  endforeach()
  string(APPEND script
         "add_test([==[${suite}]==] [==[${TEST_EXECUTABLE}]==] [==[--gtest_filter=${suite}.*]==])\n"
         "set_tests_properties([==[${suite}]==] PROPERTIES\n"
         "  WORKING_DIRECTORY [==[${TEST_WORKING_DIR}]==]\n"
         "  SKIP_REGULAR_EXPRESSION [==[camlab-tests: every test skipped]==]\n"
         "  COST ${cost}")
  set(is_name TRUE)
  foreach(item IN LISTS TEST_PROPERTIES)
    if(is_name)
      string(APPEND script "\n  ${item}")
      set(is_name FALSE)
    else()
      string(APPEND script " [==[${item}]==]")
      set(is_name TRUE)
    endif()
  endforeach()
  list(FIND SERIAL_SUITES "${suite}" serial_at)
  if(serial_at GREATER -1)
    string(APPEND script "\n  RUN_SERIAL TRUE")
  endif()
  string(APPEND script ")\n")
endforeach()
file(WRITE "${CTEST_FILE}" "${script}")
