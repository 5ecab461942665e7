# camlab_discover_test_suites(TARGET [DISCOVERY_TIMEOUT S] [PROPERTIES name value ...]
#                             [SERIAL_SUITES suite ...]):
# registers each GoogleTest suite of TARGET as one ctest test (`Suite`, run as
# `TARGET --gtest_filter=Suite.*`), found after each build by listing the executable's tests.
#
# Why suites and not tests (as GoogleTest's gtest_discover_tests registers them): every test
# process loads about 170 shared libraries (OpenCV's image codecs alone pull in 139) and
# takes 0.12 s of CPU before its first test runs; over 900 tests that was 110 s of the
# suite's 650 s. One process a suite keeps ctest's parallelism (220 suites on 2 cores) and
# the same assertions; gtest's own output still names each test and each failure.
#
# Each suite's COST comes from tests/suite_costs.txt (why there).
#
# A suite whose every test skipped (a tool absent) is reported as skipped; the executable's
# main prints the line that says so (tests/support/suite_main.h).
set(CAMLAB_DISCOVER_TEST_SUITES_SCRIPT ${CMAKE_CURRENT_LIST_DIR}/discover_test_suites.cmake)

function(camlab_discover_test_suites target)
  cmake_parse_arguments(ARG "" "DISCOVERY_TIMEOUT" "PROPERTIES;SERIAL_SUITES" ${ARGN})
  if(NOT ARG_DISCOVERY_TIMEOUT)
    set(ARG_DISCOVERY_TIMEOUT 60)
  endif()
  set(base "${CMAKE_CURRENT_BINARY_DIR}/${target}_suites")
  add_custom_command(
    TARGET ${target} POST_BUILD
    BYPRODUCTS "${base}_tests.cmake"
    COMMAND "${CMAKE_COMMAND}"
            -D "TEST_EXECUTABLE=$<TARGET_FILE:${target}>"
            -D "TEST_WORKING_DIR=${CMAKE_CURRENT_BINARY_DIR}"
            -D "TEST_PROPERTIES=${ARG_PROPERTIES}"
            -D "DISCOVERY_TIMEOUT=${ARG_DISCOVERY_TIMEOUT}"
            -D "CTEST_FILE=${base}_tests.cmake"
            -D "COST_TABLE=${PROJECT_SOURCE_DIR}/tests/suite_costs.txt"
            -D "SERIAL_SUITES=${ARG_SERIAL_SUITES}"
            -P "${CAMLAB_DISCOVER_TEST_SUITES_SCRIPT}"
    VERBATIM)
  file(WRITE "${base}_include.cmake"
       "if(EXISTS \"${base}_tests.cmake\")\n"
       "  include(\"${base}_tests.cmake\")\n"
       "else()\n"
       "  add_test(${target}_NOT_BUILT ${target}_NOT_BUILT)\n"
       "endif()\n")
  set_property(DIRECTORY APPEND PROPERTY TEST_INCLUDE_FILES "${base}_include.cmake")
endfunction()
