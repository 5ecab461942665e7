// main() of the test executables that have no main of their own (GoogleTest's gtest_main,
// plus the summary line of suite_main.h).
#include <gtest/gtest.h>

#include "suite_main.h"

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return camlab::testing::run_all_tests_and_summarise();
}
