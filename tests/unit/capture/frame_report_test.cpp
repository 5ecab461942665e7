// capture/frame_report.h: which controls a frame's metadata reports, what it should
// report for given control values, and the tolerance of the match (sensors quantise
// exposure to line times).
#include "capture/frame_report.h"

#include <gtest/gtest.h>

namespace camlab::capture {
namespace {

TEST(FrameReport, ExpectedValuesAreInTheReportsUnits) {
  EXPECT_TRUE(is_reported_control("exposure_time_absolute"));
  EXPECT_TRUE(is_reported_control("analogue_gain"));
  EXPECT_FALSE(is_reported_control("iris_absolute"));
  EXPECT_FALSE(is_reported_control("focus_absolute"));  // V4L2 steps, not dioptres
  const auto expected =
      expected_report({{"exposure_time_absolute", 40}, {"analogue_gain", 2500}, {"gain", 300}},
                      {"exposure_time_absolute", "analogue_gain", "gain"});
  ASSERT_EQ(expected.size(), 2u);
  EXPECT_DOUBLE_EQ(expected.at("exposure_us"), 4000.0);  // 40 x 100 us
  EXPECT_DOUBLE_EQ(expected.at("analogue_gain"), 2.5);   // thousandths
  EXPECT_DOUBLE_EQ(expected_report({{"exposure_time", 1234}}, {"exposure_time"}).at("exposure_us"),
                   1234.0);
}

TEST(FrameReport, AReportMatchesWithinTheSensorsQuantisation) {
  const std::map<std::string, double> expected = {{"exposure_us", 4000.0}, {"analogue_gain", 2.0}};
  device::FrameMetadata meta;
  EXPECT_FALSE(reports_all(meta, expected));
  EXPECT_FALSE(report_matches(meta, expected));
  meta.exposure_us = 4010;  // a line time off
  EXPECT_FALSE(reports_all(meta, expected));
  meta.analogue_gain = 2.03;
  EXPECT_TRUE(reports_all(meta, expected));
  EXPECT_TRUE(report_matches(meta, expected));
  meta.exposure_us = 2000;  // the previous step of a bracket
  EXPECT_FALSE(report_matches(meta, expected));
  // Short exposures: within 30 us (a few line times), though more than 5%.
  device::FrameMetadata short_meta;
  short_meta.exposure_us = 125;
  EXPECT_TRUE(report_matches(short_meta, {{"exposure_us", 100.0}}));
  short_meta.exposure_us = 140;
  EXPECT_FALSE(report_matches(short_meta, {{"exposure_us", 100.0}}));
}

TEST(FrameReport, TheSidecarHoldsOnlyWhatWasReported) {
  device::FrameMetadata meta;
  EXPECT_TRUE(report_json(meta).empty());
  meta.exposure_us = 5000;
  meta.focus_fom = 812;
  const nlohmann::json report = report_json(meta);
  EXPECT_EQ(report, nlohmann::json({{"exposure_us", 5000}, {"focus_fom", 812}}));
}

}  // namespace
}  // namespace camlab::capture
