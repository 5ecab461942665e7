// Per-region focus peaks on stacks drawn here, independently of camlab's renderer: every
// region is its own textured patch at its own (sub-step) best focus, blurred per frame by
// a uniform disk whose diameter grows by `blur_per_step` px per focus step away from it
// (the thin lens's CoC is linear in the lens travel), plus Gaussian noise. The truth is
// each region's best focus in frame steps; the claim under test is issue-grade accuracy:
// >= 90% of regions within 0.05 step, and >= 90% within two of their stated sigmas.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <opencv2/imgproc.hpp>
#include <random>
#include <vector>

#include "analysis/focus/focus_stack.h"

namespace camlab::analysis {
namespace {

// A normalised disk kernel of diameter d px, each tap the disk's area over its pixel
// (16x16 supersampled); d below 0.05 px is the identity.
cv::Mat disk_kernel(double diameter) {
  const double r = 0.5 * diameter;
  const int half = static_cast<int>(std::ceil(r + 0.5));
  cv::Mat k = cv::Mat::zeros(2 * half + 1, 2 * half + 1, CV_64F);
  if (r < 0.025) {
    k.at<double>(half, half) = 1;
    return k;
  }
  const int ss = 16;
  for (int y = -half; y <= half; ++y)
    for (int x = -half; x <= half; ++x) {
      int inside = 0;
      for (int i = 0; i < ss; ++i)
        for (int j = 0; j < ss; ++j) {
          const double px = x + (i + 0.5) / ss - 0.5, py = y + (j + 0.5) / ss - 0.5;
          inside += px * px + py * py <= r * r;
        }
      k.at<double>(y + half, x + half) = inside;
    }
  const double total = cv::sum(k)[0];
  if (total == 0) {  // a disk smaller than the supersampling grid: the centre tap only
    k.at<double>(half, half) = 1;
    return k;
  }
  return k / total;
}

struct Stack {
  std::vector<cv::Mat> frames;
  std::vector<double> truth;  // per region, row-major, in frame steps
  int region_px = 0;
};

Stack draw_stack(int region_px, int regions_x, int regions_y, int frame_count, double blur_per_step,
                 double noise_dn, unsigned seed) {
  Stack s;
  s.region_px = region_px;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> best(3.0, frame_count - 4.0);
  // Each region's texture stops `margin` px short of its borders (flat grey beyond, the
  // texture's mean), so that no region's blur or focus window reaches its neighbours:
  // a seam between regions at different focus would add Laplacian energy of its own.
  const int margin = 10;
  const int pad = static_cast<int>(std::ceil(blur_per_step * frame_count)) + 2;
  std::vector<cv::Mat> patches;
  for (int r = 0; r < regions_x * regions_y; ++r) {
    s.truth.push_back(best(rng));
    cv::Mat texture(region_px + 2 * pad, region_px + 2 * pad, CV_64F, cv::Scalar(0.5));
    cv::Mat inner = texture(
        cv::Rect(pad + margin, pad + margin, region_px - 2 * margin, region_px - 2 * margin));
    cv::randu(inner, 0.0, 1.0);
    cv::GaussianBlur(inner, inner, {0, 0}, 1.0);  // features of a few px
    patches.push_back(texture);
  }
  std::normal_distribution<double> noise(0.0, noise_dn);
  const int width = regions_x * region_px, height = regions_y * region_px;
  for (int f = 0; f < frame_count; ++f) {
    cv::Mat frame(height, width, CV_16UC1);
    for (int r = 0; r < regions_x * regions_y; ++r) {
      const int ox = (r % regions_x) * region_px, oy = (r / regions_x) * region_px;
      cv::Mat blurred;
      cv::filter2D(patches[static_cast<size_t>(r)], blurred, -1,
                   disk_kernel(blur_per_step * std::fabs(f - s.truth[static_cast<size_t>(r)])),
                   {-1, -1}, 0, cv::BORDER_REFLECT);
      for (int y = 0; y < region_px; ++y)
        for (int x = 0; x < region_px; ++x) {
          const double v = 400 + 3000 * blurred.at<double>(y + pad, x + pad) + noise(rng);
          frame.at<uint16_t>(oy + y, ox + x) =
              static_cast<uint16_t>(std::clamp(std::lround(v), 0L, 4095L));
        }
    }
    s.frames.push_back(frame);
  }
  return s;
}

struct Score {
  int ok = 0, within_005 = 0, within_2_sigma = 0, zero_sigma = 0;
  double worst = 0;
};

Score score(const Stack& s, const FocusStackResult& result) {
  Score out;
  for (size_t r = 0; r < result.regions.size(); ++r) {
    const RegionFocus& rf = result.regions[r];
    if (rf.status != kFocusOk) continue;
    ++out.ok;
    const double error = std::fabs(rf.best_index - s.truth[r]);
    out.worst = std::max(out.worst, error);
    out.within_005 += error <= 0.05;
    out.within_2_sigma += error <= 2 * rf.best_index_sigma;
    out.zero_sigma += !(rf.best_index_sigma > 0);
  }
  return out;
}

void check_regions(int region_px, unsigned seed) {
  const Stack s = draw_stack(region_px, 512 / region_px, 256 / region_px, 12, 1.3, 6.0, seed);
  FocusStackOptions options;
  options.region_px = region_px;
  options.black_level = 400;
  FocusStackAccumulator acc(options);
  for (const cv::Mat& f : s.frames) ASSERT_TRUE(acc.add(f).ok());
  auto result = acc.finish();
  ASSERT_TRUE(result.ok()) << result.error().message;
  const Score sc = score(s, *result);
  const int n = static_cast<int>(s.truth.size());
  if (std::getenv("CAMLAB_EDGE_REPORT"))
    std::cout << region_px << " px regions, seed " << seed << ": " << sc.ok << "/" << n << " ok, "
              << sc.within_005 << " within 0.05 step, " << sc.within_2_sigma << " within 2 sigma, "
              << sc.zero_sigma << " with sigma 0, worst " << sc.worst << " step\n";
  EXPECT_EQ(sc.ok, n) << "every region has texture and an inside peak";
  EXPECT_GE(sc.within_005, 0.9 * n) << region_px << " px, worst " << sc.worst;
  EXPECT_GE(sc.within_2_sigma, 0.9 * n) << region_px << " px";
  EXPECT_EQ(sc.zero_sigma, 0) << "a stated sigma is never 0";
}

TEST(FocusPeak, SixtyFourPixelRegionsWithinAStepTwentiethAndHonestSigma) {
  for (unsigned seed : {1u, 2u}) check_regions(64, seed);
}

TEST(FocusPeak, ThirtyTwoPixelRegionsWithinAStepTwentiethAndHonestSigma) {
  for (unsigned seed : {3u, 4u}) check_regions(32, seed);
}

}  // namespace
}  // namespace camlab::analysis
