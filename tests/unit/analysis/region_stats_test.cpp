// Statistics of a frame's rectangle (analysis/region_stats.h) on frames whose every sample
// is known: each CFA site its own value, colour planes in stored B, G, R order, and a
// 16-bit patch of large values with small spread, checked against a two-pass sum in long
// double (a one-pass sum of squares would lose the spread to cancellation).
#include "analysis/region_stats.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <random>

namespace camlab::analysis {
namespace {

image::FrameSidecar mosaic_sidecar(const std::string& pattern, int black) {
  image::FrameSidecar s;
  s.layout = image::FrameLayout::kMosaic;
  s.cfa_pattern = pattern;
  s.bit_depth = 12;
  s.black_level_dn = black;
  return s;
}

std::map<std::string, RegionChannelStats> by_name(const RegionStats& r) {
  std::map<std::string, RegionChannelStats> out;
  for (const auto& c : r.channels) out[c.channel] = c;
  return out;
}

TEST(RegionStats, EachMosaicSiteIsItsOwnChannelAndUnderTheCursorItsOwnValue) {
  // GRBG: sites Gr, R / B, Gb with values 1000, 2000 / 300, 1010.
  cv::Mat image(8, 10, CV_16UC1);
  const uint16_t site_dn[4] = {1000, 2000, 300, 1010};
  for (int y = 0; y < image.rows; ++y)
    for (int x = 0; x < image.cols; ++x) image.at<uint16_t>(y, x) = site_dn[(y & 1) * 2 + (x & 1)];
  const auto sidecar = mosaic_sidecar("GRBG", 64);

  // A 2x2 cell at an odd origin: still one sample per site, each named by its filter.
  auto cell = region_stats(image, sidecar, cv::Rect(3, 5, 2, 2));
  ASSERT_TRUE(cell.ok()) << cell.error().message;
  ASSERT_EQ(cell->samples.size(), 4u);
  std::map<std::string, int> under_cursor;
  for (const auto& s : cell->samples) under_cursor[s.channel] = s.dn;
  EXPECT_EQ(under_cursor,
            (std::map<std::string, int>{{"Gr", 1000}, {"R", 2000}, {"B", 300}, {"Gb", 1010}}));
  // (3, 5): odd column on an odd row of GRBG is Gb.
  EXPECT_EQ(cell->samples[0].channel, "Gb");
  EXPECT_EQ(cell->samples[0].dn, 1010);

  // The whole frame: flat channels, mean the site value, no spread, so no SNR.
  auto whole = region_stats(image, sidecar, cv::Rect(0, 0, 10, 8));
  ASSERT_TRUE(whole.ok());
  EXPECT_TRUE(whole->samples.empty());  // 80 samples: more than are listed
  const auto c = by_name(*whole);
  ASSERT_EQ(c.size(), 4u);
  EXPECT_EQ(c.at("R").samples, 20u);
  EXPECT_DOUBLE_EQ(c.at("R").mean_dn, 2000);
  EXPECT_DOUBLE_EQ(c.at("B").sd_dn, 0);
  EXPECT_FALSE(c.at("Gb").snr.has_value());

  // One pixel of a mosaic holds one site: one channel, no others invented.
  auto one = region_stats(image, sidecar, cv::Rect(1, 0, 1, 1));
  ASSERT_TRUE(one.ok());
  ASSERT_EQ(one->channels.size(), 1u);
  EXPECT_EQ(one->channels[0].channel, "R");
  EXPECT_EQ(one->channels[0].min_dn, 2000);
}

TEST(RegionStats, ColourPlanesAreNamedRgbFromStoredBgr) {
  cv::Mat image(4, 4, CV_8UC3, cv::Scalar(10, 20, 30));  // B, G, R
  image::FrameSidecar sidecar;
  sidecar.layout = image::FrameLayout::kRgb;
  auto r = region_stats(image, sidecar, cv::Rect(1, 1, 1, 1));
  ASSERT_TRUE(r.ok()) << r.error().message;
  const auto c = by_name(*r);
  EXPECT_DOUBLE_EQ(c.at("R").mean_dn, 30);
  EXPECT_DOUBLE_EQ(c.at("G").mean_dn, 20);
  EXPECT_DOUBLE_EQ(c.at("B").mean_dn, 10);
  ASSERT_EQ(r->samples.size(), 3u);
}

TEST(RegionStats, LargeValuesWithSmallSpreadKeepTheirSpread) {
  // Mean 60000 DN, sd 1.5 DN: a sum of squares in double would lose the sd.
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(60000, 1.5);
  cv::Mat image(64, 64, CV_16UC1);
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 64; ++x)
      image.at<uint16_t>(y, x) = static_cast<uint16_t>(std::lround(noise(rng)));
  image::FrameSidecar sidecar;
  sidecar.bit_depth = 16;
  sidecar.black_level_dn = 4096;
  const cv::Rect roi(5, 7, 40, 30);
  long double sum = 0;
  for (int y = roi.y; y < roi.y + roi.height; ++y)
    for (int x = roi.x; x < roi.x + roi.width; ++x) sum += image.at<uint16_t>(y, x);
  const long double mean = sum / roi.area();
  long double squares = 0;
  for (int y = roi.y; y < roi.y + roi.height; ++y)
    for (int x = roi.x; x < roi.x + roi.width; ++x)
      squares += (image.at<uint16_t>(y, x) - mean) * (image.at<uint16_t>(y, x) - mean);
  const double sd = static_cast<double>(std::sqrt(squares / (roi.area() - 1)));

  auto r = region_stats(image, sidecar, roi);
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_EQ(r->channels.size(), 1u);
  const auto& y = r->channels[0];
  EXPECT_EQ(y.channel, "Y");
  EXPECT_EQ(y.samples, 1200u);
  EXPECT_NEAR(y.mean_dn, static_cast<double>(mean), 1e-9);
  EXPECT_NEAR(y.sd_dn, sd, 1e-9);
  ASSERT_TRUE(y.snr.has_value());
  EXPECT_NEAR(*y.snr, (static_cast<double>(mean) - 4096) / sd, 1e-6);
}

TEST(RegionStats, ARegionOutsideTheFrameIsRefusedWithTheFramesSize) {
  cv::Mat image(48, 64, CV_8UC1, cv::Scalar(5));
  image::FrameSidecar sidecar;
  for (const cv::Rect& bad : {cv::Rect(60, 0, 8, 8), cv::Rect(0, 0, 0, 1), cv::Rect(-1, 0, 2, 2),
                              cv::Rect(0, 47, 1, 2)}) {
    auto r = region_stats(image, sidecar, bad);
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().code, "out_of_range");
    EXPECT_NE(r.error().message.find("64 x 48"), std::string::npos) << r.error().message;
  }
  auto unknown = region_stats(image, mosaic_sidecar("RGBG", 0), cv::Rect(0, 0, 2, 2));
  ASSERT_FALSE(unknown.ok());
  EXPECT_EQ(unknown.error().code, "invalid_argument");
}

}  // namespace
}  // namespace camlab::analysis
