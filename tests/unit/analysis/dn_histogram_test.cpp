// Histograms of raw DN (analysis/dn_histogram.h) on frames whose every sample is known:
// each CFA site filled with its own value, a ramp holding every 12-bit value once, and
// colour planes; the counts, clipping tallies and means are what the construction says.
#include "analysis/dn_histogram.h"

#include <gtest/gtest.h>

#include <map>

namespace camlab::analysis {
namespace {

// A mosaic with the value of each 2x2 site given in row-major site order.
cv::Mat mosaic(int cols, int rows, std::array<uint16_t, 4> site_dn) {
  cv::Mat image(rows, cols, CV_16UC1);
  for (int y = 0; y < rows; ++y)
    for (int x = 0; x < cols; ++x)
      image.at<uint16_t>(y, x) = site_dn[static_cast<size_t>((y & 1) * 2 + (x & 1))];
  return image;
}

std::map<std::string, const ChannelHistogram*> by_name(const DnHistogram& h) {
  std::map<std::string, const ChannelHistogram*> out;
  for (const auto& c : h.channels) out[c.channel] = &c;
  return out;
}

TEST(DnHistogram, EachCfaSiteIsCountedUnderItsOwnColour) {
  for (const auto& [pattern, sites] :
       std::map<std::string, std::array<std::string, 4>>{{"RGGB", {"R", "Gr", "Gb", "B"}},
                                                         {"BGGR", {"B", "Gb", "Gr", "R"}},
                                                         {"GRBG", {"Gr", "R", "B", "Gb"}},
                                                         {"GBRG", {"Gb", "B", "R", "Gr"}}}) {
    SCOPED_TRACE(pattern);
    // Site values 100, 1000, 2000, 4095 (clipped) with 12 bits, black level 64.
    const std::array<uint16_t, 4> dn = {100, 1000, 2000, 4095};
    DnHistogramInput input{mosaic(16, 10, dn), image::FrameLayout::kMosaic, pattern, 12, 64, 4095};
    auto h = dn_histogram(input, 256);
    ASSERT_TRUE(h.ok()) << h.error().message;
    EXPECT_EQ(h->bin_width_dn, 16);
    EXPECT_EQ(h->bins, 256);
    auto channels = by_name(*h);
    ASSERT_EQ(channels.size(), 4u);
    for (int site = 0; site < 4; ++site) {
      const ChannelHistogram& c = *channels.at(sites[static_cast<size_t>(site)]);
      EXPECT_EQ(c.samples, 40u);  // a quarter of 16 x 10
      EXPECT_EQ(c.counts[dn[static_cast<size_t>(site)] / 16], 40u);
      EXPECT_DOUBLE_EQ(c.mean_dn, dn[static_cast<size_t>(site)]);
      EXPECT_EQ(c.at_or_above_white, site == 3 ? 40u : 0u);
      EXPECT_EQ(c.at_or_below_black, 0u);
    }
    EXPECT_EQ(h->channels.front().channel, "R");  // reported in a fixed order
  }
}

TEST(DnHistogram, ARampOfEveryValueFillsEveryBinEqually) {
  cv::Mat ramp(64, 64, CV_16UC1);
  for (int i = 0; i < 4096; ++i) ramp.at<uint16_t>(i / 64, i % 64) = static_cast<uint16_t>(i);
  DnHistogramInput input{ramp, image::FrameLayout::kMono, "", 12, 256, 4000};
  for (int bins : {4096, 1000, 256, 7, 1}) {
    SCOPED_TRACE(bins);
    auto h = dn_histogram(input, bins);
    ASSERT_TRUE(h.ok()) << h.error().message;
    ASSERT_EQ(h->channels.size(), 1u);
    const ChannelHistogram& y = h->channels[0];
    EXPECT_EQ(y.channel, "Y");
    EXPECT_EQ(h->bins * h->bin_width_dn >= 4096, true);
    EXPECT_LT((h->bins - 1) * h->bin_width_dn, 4096);
    uint64_t total = 0;
    for (int b = 0; b < h->bins; ++b) {
      const int first = b * h->bin_width_dn;
      const int last = std::min(4095, first + h->bin_width_dn - 1);
      EXPECT_EQ(y.counts[static_cast<size_t>(b)], static_cast<uint64_t>(last - first + 1));
      total += y.counts[static_cast<size_t>(b)];
    }
    EXPECT_EQ(total, 4096u);
    EXPECT_EQ(y.at_or_below_black, 257u);  // 0..256
    EXPECT_EQ(y.at_or_above_white, 96u);   // 4000..4095
    EXPECT_DOUBLE_EQ(y.mean_dn, 2047.5);
    EXPECT_EQ(y.min_dn, 0);
    EXPECT_EQ(y.max_dn, 4095);
  }
}

TEST(DnHistogram, ColourPlanesAreReportedRedGreenBlue) {
  cv::Mat bgr(4, 6, CV_8UC3, cv::Scalar(10, 128, 255));  // B, G, R
  DnHistogramInput input{bgr, image::FrameLayout::kRgb, "", 8, 0, 255};
  auto h = dn_histogram(input, 256);
  ASSERT_TRUE(h.ok()) << h.error().message;
  ASSERT_EQ(h->channels.size(), 3u);
  EXPECT_EQ(h->channels[0].channel, "R");
  EXPECT_DOUBLE_EQ(h->channels[0].mean_dn, 255);
  EXPECT_EQ(h->channels[0].at_or_above_white, 24u);
  EXPECT_EQ(h->channels[1].channel, "G");
  EXPECT_EQ(h->channels[1].counts[128], 24u);
  EXPECT_EQ(h->channels[2].channel, "B");
  EXPECT_DOUBLE_EQ(h->channels[2].mean_dn, 10);
}

TEST(DnHistogram, BadInputIsRefusedWithTheReason) {
  const cv::Mat grey(4, 4, CV_8UC1, cv::Scalar(3));
  EXPECT_EQ(dn_histogram({cv::Mat(), image::FrameLayout::kMono, "", 8, 0, 255}, 256).error().code,
            ErrorCode::kInvalidArgument);
  EXPECT_EQ(dn_histogram({grey, image::FrameLayout::kMono, "", 12, 0, 255}, 256).error().code,
            ErrorCode::kInvalidArgument);  // 12 bits cannot be in 8-bit samples
  EXPECT_EQ(dn_histogram({grey, image::FrameLayout::kMono, "", 8, 0, 255}, 0).error().code,
            ErrorCode::kInvalidArgument);
  EXPECT_EQ(dn_histogram({grey, image::FrameLayout::kMosaic, "RGBG", 8, 0, 255}, 256).error().code,
            ErrorCode::kInvalidArgument);
  EXPECT_EQ(
      dn_histogram({cv::Mat(3, 4, CV_8UC1), image::FrameLayout::kMosaic, "RGGB", 8, 0, 255}, 256)
          .error()
          .code,
      ErrorCode::kInvalidArgument);
  cv::Mat floats(4, 4, CV_32FC1);
  EXPECT_EQ(dn_histogram({floats, image::FrameLayout::kMono, "", 8, 0, 255}, 256).error().code,
            ErrorCode::kInvalidArgument);
}

}  // namespace
}  // namespace camlab::analysis
