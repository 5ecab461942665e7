// The error vocabulary (base/error_code.h): a closed set whose every code has one name, a
// meaning and an HTTP status, and that reads and prints as its name.
#include "base/error_code.h"

#include <gtest/gtest.h>

#include <fstream>
#include <set>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "base/result.h"

namespace camlab {
namespace {

TEST(ErrorCode, EveryCodeHasAUniqueSnakeCaseNameAMeaningAndAnHttpErrorStatus) {
  std::set<std::string_view> names;
  for (const ErrorCodeInfo& info : kErrorCodes) {
    EXPECT_TRUE(names.insert(info.name).second) << "two codes are named " << info.name;
    ASSERT_FALSE(info.name.empty());
    for (char c : info.name) EXPECT_TRUE((c >= 'a' && c <= 'z') || c == '_') << info.name;
    EXPECT_GE(info.meaning.size(), 10u) << info.name << " needs a meaning users can read";
    EXPECT_GE(info.http_status, 400) << info.name;
    EXPECT_LE(info.http_status, 599) << info.name;
    EXPECT_EQ(&info_of(info.code), &info) << info.name << " is out of the enum's order";
  }
  EXPECT_EQ(names.size(), static_cast<size_t>(ErrorCode::kInternal) + 1);
}

TEST(ErrorCode, NamesReadBackToTheirCodes) {
  for (const ErrorCodeInfo& info : kErrorCodes) {
    auto found = find_error_code(info.name);
    ASSERT_TRUE(found.has_value()) << info.name;
    EXPECT_EQ(*found, info.code);
  }
  EXPECT_FALSE(find_error_code("").has_value());
  EXPECT_FALSE(find_error_code("out_of_rnage").has_value());
  EXPECT_FALSE(find_error_code("Out_Of_Range").has_value());
}

TEST(ErrorCode, ComparesPrintsAndSerialisesAsItsName) {
  const Error error = make_error("out_of_range", "gain = 900 is outside [0, 480]");
  EXPECT_EQ(error.code, ErrorCode::kOutOfRange);
  EXPECT_TRUE(error.code == "out_of_range");
  EXPECT_FALSE(error.code == "out_of_rang");
  std::ostringstream printed;
  printed << error.code;
  EXPECT_EQ(printed.str(), "out_of_range");
  // JSON must carry the name, never the enum's number.
  const nlohmann::json json = {{"code", error.code}};
  EXPECT_EQ(json.dump(), R"({"code":"out_of_range"})");
  EXPECT_EQ(error.text(), "out_of_range: gain = 900 is outside [0, 480]");
}

TEST(ErrorCode, ContextGoesBeforeTheMessageAndKeepsTheCode) {
  const Error error = make_error("no_device", "/dev/video0: the camera is gone");
  const Error wrapped = error.with_context("setting gain = 5: ");
  EXPECT_EQ(wrapped.code, ErrorCode::kNoDevice);
  EXPECT_EQ(wrapped.message, "setting gain = 5: /dev/video0: the camera is gone");
}

TEST(ErrorCode, StatusAndResultCarryTheError) {
  Status ok;
  EXPECT_TRUE(ok.ok());
  Status failed = make_error("busy", "streaming");
  ASSERT_FALSE(failed.ok());
  EXPECT_EQ(failed.error().code, ErrorCode::kBusy);
  Result<int> value = 3;
  EXPECT_EQ(*value, 3);
  Result<int> missing = make_error(ErrorCode::kNotFound, "no job 7");
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.error().message, "no job 7");
}

TEST(ErrorCode, TheUsersPageListsEveryCodeWithItsStatus) {
  std::ifstream page(std::string(CAMLAB_SOURCE_DIR) + "/docs/errors.md");
  ASSERT_TRUE(page) << "docs/errors.md is missing";
  std::stringstream text;
  text << page.rdbuf();
  for (const ErrorCodeInfo& info : kErrorCodes) {
    const std::string row =
        "| `" + std::string(info.name) + "` | " + std::to_string(info.http_status) + " |";
    EXPECT_NE(text.str().find(row), std::string::npos) << "docs/errors.md has no row " << row;
  }
}

}  // namespace
}  // namespace camlab
