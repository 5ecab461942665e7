// GoogleTest's main for the suite, with the summary line ctest reads (suite_main.h).
#include "suite_main.h"

#include <cstdio>

#include <gtest/gtest.h>

namespace camlab::testing {

int run_all_tests_and_summarise() {
  const int status = RUN_ALL_TESTS();
  const auto& unit = *::testing::UnitTest::GetInstance();
  const int passed = unit.successful_test_count();
  const int skipped = unit.skipped_test_count();
  const int failed = unit.failed_test_count();
  const bool all_skipped = passed == 0 && failed == 0 && skipped > 0;
  std::printf("camlab-tests: %d passed, %d skipped, %d failed\n", passed, skipped, failed);
  if (all_skipped) std::printf("camlab-tests: every test skipped\n");
  std::fflush(stdout);
  return status;
}

}  // namespace camlab::testing
