// Data file modes (base/file_mode.h): the --file-mode parser's rules, and the default
// following the umask as open(2) would.
#include "base/file_mode.h"

#include <gtest/gtest.h>
#include <sys/stat.h>

namespace camlab {
namespace {

TEST(DataFileMode, ParsesOctalModesThatKeepTheOwnersReadAndWrite) {
  for (auto [text, mode] :
       {std::pair{"0640", 0640}, {"640", 0640}, {"0600", 0600}, {"0666", 0666}, {"0644", 0644}}) {
    auto parsed = parse_data_file_mode(text);
    ASSERT_TRUE(parsed.ok()) << text << ": " << parsed.error().message;
    EXPECT_EQ(*parsed, static_cast<mode_t>(mode)) << text;
  }
}

TEST(DataFileMode, RefusesExecuteBitsSetuidLockingOutTheOwnerAndNonOctal) {
  for (const char* text : {"0755", "0700", "4644", "0400", "0240", "0066", "0648", "rw-r-----", "",
                           "06400", "-644", "0x1a4"}) {
    auto parsed = parse_data_file_mode(text);
    ASSERT_FALSE(parsed.ok()) << text;
    EXPECT_EQ(parsed.error().code, "invalid_argument") << text;
    EXPECT_NE(parsed.error().message.find("0600 .. 0666"), std::string::npos)
        << parsed.error().message;
  }
}

// Run before any test sets a mode (ctest runs each test in its own process).
TEST(DataFileMode, DefaultsTo0666LessTheUmask) {
  const mode_t mask = ::umask(022);
  ::umask(mask);
  EXPECT_EQ(data_file_mode(), static_cast<mode_t>(0666 & ~mask));
  set_data_file_mode(0640);
  EXPECT_EQ(data_file_mode(), static_cast<mode_t>(0640));
}

}  // namespace
}  // namespace camlab
