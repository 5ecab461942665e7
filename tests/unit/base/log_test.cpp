// The log's settings (base/log.h): CAMLAB_LOG parsed into a threshold per category.
#include "base/log.h"

#include <gtest/gtest.h>

#include <string>

namespace camlab::log {
namespace {

TEST(Log, InfoForEveryCategoryByDefault) {
  std::string bad;
  const Thresholds t = parse_thresholds("", &bad);
  EXPECT_TRUE(bad.empty());
  for (Category c : {Category::kDaemon, Category::kHttp, Category::kJobs, Category::kCameras,
                     Category::kCalib, Category::kVcam})
    EXPECT_EQ(t.of(c), Level::kInfo) << name_of(c);
}

TEST(Log, ALevelAloneSetsEveryCategoryAndACategoryItemOverridesIt) {
  std::string bad;
  const Thresholds t = parse_thresholds("warning,calib=debug,http=off", &bad);
  EXPECT_TRUE(bad.empty()) << bad;
  EXPECT_EQ(t.of(Category::kJobs), Level::kWarning);
  EXPECT_EQ(t.of(Category::kCalib), Level::kDebug);
  EXPECT_EQ(t.of(Category::kHttp), Level::kOff);
}

TEST(Log, MalformedItemsAreListedAndTheRestStillApplies) {
  std::string bad;
  const Thresholds t = parse_thresholds("calib=loud,,noise,vcam=error,=debug", &bad);
  EXPECT_EQ(bad, "calib=loud, noise, =debug");
  EXPECT_EQ(t.of(Category::kVcam), Level::kError);
  EXPECT_EQ(t.of(Category::kCalib), Level::kInfo);
}

TEST(Log, NamesAreThoseUsersWrite) {
  EXPECT_EQ(name_of(Category::kDaemon), "camlabd");
  EXPECT_EQ(name_of(Category::kCalib), "calib");
  EXPECT_EQ(name_of(Level::kWarning), "warning");
}

}  // namespace
}  // namespace camlab::log
