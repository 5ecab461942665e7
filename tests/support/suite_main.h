// The main of every GoogleTest executable (suite_main.cpp): ctest runs one process per test
// suite (cmake/test_suites.cmake), and this says, in a line ctest reads, when every test of
// the run was skipped, so that a suite skipped whole is reported as skipped while a suite
// with one skipped test and one failed test still fails.
#pragma once

namespace camlab::testing {

// RUN_ALL_TESTS() and then one line, `camlab-tests: P passed, S skipped, F failed`, and a
// second, `camlab-tests: every test skipped`, when nothing passed or failed and something
// was skipped (ctest's skip expression; a list separator in it would split it in two).
int run_all_tests_and_summarise();

}  // namespace camlab::testing
