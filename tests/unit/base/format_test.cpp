// Number formatting (base/format.h).
#include "base/format.h"

#include <gtest/gtest.h>

#include <limits>
#include <string>

namespace camlab {
namespace {

TEST(Format, SignificantDigits) {
  EXPECT_EQ(format_significant(0.000123456, 3), "0.000123");
  EXPECT_EQ(format_significant(1.5e6, 3), "1.5e+06");
  EXPECT_EQ(format_significant(2.0 / 3.0), "0.666667");
  EXPECT_EQ(format_significant(-5, 10), "-5");
  EXPECT_EQ(format_significant(std::numeric_limits<double>::infinity(), 10), "inf");
  EXPECT_EQ(format_significant(std::numeric_limits<double>::quiet_NaN(), 3), "nan");
}

TEST(Format, PrintfOfAnyLength) {
  EXPECT_EQ(format_printf("%.2f px", 1.234), "1.23 px");
  const std::string long_text(500, 'x');
  const std::string formatted = format_printf("[%s] %d", long_text.c_str(), 42);
  EXPECT_EQ(formatted.size(), 500u + 5u);
  EXPECT_EQ(formatted.substr(formatted.size() - 4), "] 42");
  EXPECT_EQ(format_printf("%s", ""), "");
}

}  // namespace
}  // namespace camlab
