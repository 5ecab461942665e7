// Depth from focus on a Bayer focus stack drawn here, independently of camlab's renderer:
// a random texture blurred per channel by a Gaussian whose sigma grows linearly with the
// distance of the focus position from that channel's best focus (R at 4, G at 5, B at 6
// steps: longitudinal chromatic aberration), then sampled into an RGGB mosaic.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <opencv2/imgproc.hpp>
#include <string>

#include "analysis/focus/focus_report.h"
#include "image/capture_folder.h"

namespace camlab::analysis {
namespace {
// Named too: the test files of an executable share a unity build's translation unit.
namespace colour_focus_test {

namespace fs = std::filesystem;

constexpr double kBestPosition[3] = {4.0, 5.0, 6.0};  // R, G, B
constexpr double kSigmaPerStep = 0.9;                 // px of blur per step off focus
const std::string kCfa = "RGGB";

double median_best(const FocusReport& r) {
  std::vector<double> best;
  for (const auto& rr : r.regions)
    if (rr.focus.status == kFocusOk) best.push_back(rr.best_position);
  if (best.empty()) return NAN;
  std::sort(best.begin(), best.end());
  return best[best.size() / 2];
}

TEST(ColourFocus, EachChannelPeaksAtItsOwnFocusAndLuminanceBetween) {
  const fs::path dir =
      fs::temp_directory_path() / ("camlab_colour_focus_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  cv::Mat texture(256, 256, CV_32F);
  cv::RNG rng(3);
  rng.fill(texture, cv::RNG::UNIFORM, 0.0, 1.0);
  cv::GaussianBlur(texture, texture, {0, 0}, 1.2);  // features a few px wide
  auto writer = image::CaptureFolderWriter::create(dir, "focus_stack", {{"backend", "test"}}, {});
  ASSERT_TRUE(writer.ok());
  for (int p = 0; p <= 10; ++p) {
    cv::Mat channel[3];
    for (int c = 0; c < 3; ++c) {
      const double sigma = kSigmaPerStep * std::fabs(p - kBestPosition[c]);
      channel[c] = sigma > 0.05 ? cv::Mat() : texture.clone();
      if (sigma > 0.05)
        cv::GaussianBlur(texture, channel[c], {0, 0}, sigma, sigma, cv::BORDER_REFLECT);
    }
    cv::Mat mosaic(texture.size(), CV_16UC1);
    for (int y = 0; y < mosaic.rows; ++y)
      for (int x = 0; x < mosaic.cols; ++x) {
        const char colour = kCfa[static_cast<size_t>(2 * (y % 2) + x % 2)];
        const int c = colour == 'R' ? 0 : colour == 'G' ? 1 : 2;
        mosaic.at<uint16_t>(y, x) =
            static_cast<uint16_t>(std::lround(200 + 3000 * channel[c].at<float>(y, x)));
      }
    image::FrameSidecar side;
    side.sequence = static_cast<uint64_t>(p);
    side.pixel_format = "SRGGB12";
    side.layout = image::FrameLayout::kMosaic;
    side.cfa_pattern = kCfa;
    side.bit_depth = 12;
    side.black_level_dn = 200;
    side.settings = {{"focus_position", p}};
    ASSERT_TRUE(writer->add_frame(mosaic, side).ok());
  }
  ASSERT_TRUE(writer->finish().ok());

  FocusStackOptions options;
  options.region_px = 32;
  auto report = analyze_focus(dir, options);
  ASSERT_TRUE(report.ok()) << report.error().message;
  if (std::getenv("CAMLAB_EDGE_REPORT")) {
    std::cout << "luminance " << median_best(*report);
    for (const auto& c : report->channels) std::cout << ", " << c.channel << " " << median_best(c);
    std::cout << "\n";
  }
  ASSERT_EQ(report->channels.size(), 3u);
  for (int c = 0; c < 3; ++c) {
    const FocusReport& one = report->channels[static_cast<size_t>(c)];
    EXPECT_EQ(one.valid.cols, 128) << "one sample plane: half resolution";
    EXPECT_NEAR(median_best(one), kBestPosition[c], 0.25) << one.channel;
  }
  const double luminance = median_best(*report);
  EXPECT_GT(luminance, kBestPosition[0]);
  EXPECT_LT(luminance, kBestPosition[2]);
  EXPECT_EQ(to_json(*report)["channels"]["R"]["pixel_scale"], 2.0);
  fs::remove_all(dir);
}

}  // namespace colour_focus_test
}  // namespace
}  // namespace camlab::analysis
