// Two tilted dark squares side by side (8 edges, the facing sides 6-10 px apart), defocused
// from 3.5 to 19 px, drawn by a generator that shares nothing with the analysis: the scene
// sampled at 4 x 4 points per pixel, blurred by a disk kernel whose taps are the disk's
// area share of each cell (8 x 8 samples), averaged back to pixels, noise at CNR 50. Every
// side is listed as a truth lists them. Each side's diameter must be within 2% of the truth
// or within its interval widened 2x, or flagged: a window whose ends reach into the blur of
// the sides that meet it there reads D low with a tight interval (9.7 px, 95% [9.1, 10.3],
// for 19 px, before a D found was checked in a window clear of twice its blur).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "analysis/edge/edge_measure.h"

namespace camlab::analysis {
namespace {

constexpr int kSubsamples = 4;

struct Square {
  double cx, cy, half, angle_rad;
  bool contains(double x, double y) const {
    const double c = std::cos(angle_rad), s = std::sin(angle_rad), dx = x - cx, dy = y - cy;
    return std::fabs(c * dx + s * dy) <= half && std::fabs(-s * dx + c * dy) <= half;
  }
  // Side k (0..3) as an edge segment from corner k to corner k + 1.
  EdgeSegment side(int k, const std::string& name) const {
    static const double corner[5][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}, {-1, -1}};
    const double c = std::cos(angle_rad), s = std::sin(angle_rad);
    auto x = [&](int i) { return cx + half * (c * corner[i][0] - s * corner[i][1]); };
    auto y = [&](int i) { return cy + half * (s * corner[i][0] + c * corner[i][1]); };
    return {name, x(k), y(k), x(k + 1), y(k + 1), 0};
  }
};

// Light ground (1000) with dark squares (200) under a disk of `diameter` px.
cv::Mat draw(const std::vector<Square>& squares, double diameter, int size, unsigned seed) {
  const int n = size * kSubsamples;
  cv::Mat dark(n, n, CV_32F);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const double x = (j + 0.5) / kSubsamples - 0.5, y = (i + 0.5) / kSubsamples - 0.5;
      bool in = false;
      for (const Square& q : squares) in |= q.contains(x, y);
      dark.at<float>(i, j) = in ? 1.f : 0.f;
    }
  const double radius = 0.5 * diameter * kSubsamples;
  const int r = static_cast<int>(std::ceil(radius));
  cv::Mat kernel(2 * r + 1, 2 * r + 1, CV_32F);
  for (int i = -r; i <= r; ++i)
    for (int j = -r; j <= r; ++j) {
      int inside = 0;
      for (int a = 0; a < 8; ++a)
        for (int b = 0; b < 8; ++b)
          inside += std::hypot(j - 0.5 + (b + 0.5) / 8, i - 0.5 + (a + 0.5) / 8) <= radius;
      kernel.at<float>(i + r, j + r) = static_cast<float>(inside);
    }
  kernel /= cv::sum(kernel)[0];
  cv::filter2D(dark, dark, CV_32F, kernel, cv::Point(-1, -1), 0, cv::BORDER_REPLICATE);
  cv::Mat pixels;
  cv::resize(dark, pixels, cv::Size(size, size), 0, 0, cv::INTER_AREA);
  cv::Mat image = 1000.0 - 800.0 * pixels;
  cv::Mat noise(image.size(), CV_32F);
  cv::RNG rng(seed);
  rng.fill(noise, cv::RNG::NORMAL, 0.0, 800.0 / 50);
  return image + noise;
}

TEST(TiltedSquares, EverySideRightOrFlaggedAsTheBlurGrows) {
  struct Layout {
    double half, gap;
  };
  int measured = 0, flagged = 0, wrong = 0;
  unsigned seed = 3;
  for (const Layout& layout : {Layout{20, 6}, Layout{15, 10}})
    for (double diameter : {3.5, 6.0, 10.0, 19.0}) {
      const double h = layout.half, g = layout.gap;
      const std::vector<Square> squares = {{150 - h - g / 2, 150, h, 0.17},
                                           {150 + h + g / 2, 152, h, 0.12}};
      const cv::Mat image = draw(squares, diameter, 300, seed++);
      std::vector<EdgeSegment> sides;
      for (size_t q = 0; q < squares.size(); ++q)
        for (int k = 0; k < 4; ++k)
          sides.push_back(squares[q].side(k, "sq" + std::to_string(q) + "_" + std::to_string(k)));
      for (const EdgeSegment& side : sides) {
        auto m = measure_edge(image, side, sides, {});
        ASSERT_TRUE(m.ok()) << m.error().message;
        if (m->status != kEdgeOk) {
          ++flagged;
          continue;
        }
        ++measured;
        const double error = m->diameter_px - diameter;
        const double low = m->diameter_px - 2 * (m->diameter_px - m->ci_low_px),
                     high = m->diameter_px + 2 * (m->ci_high_px - m->diameter_px);
        const bool right =
            std::fabs(error) <= 0.02 * diameter || (diameter >= low && diameter <= high);
        wrong += right ? 0 : 1;
        EXPECT_TRUE(right) << "squares " << 2 * h << " px, gap " << g << " px, D " << diameter
                           << ", " << side.name << ": " << m->diameter_px << " [" << m->ci_low_px
                           << ", " << m->ci_high_px << "]"
                           << (m->joint_with.empty() ? "" : " joint");
      }
      std::printf("squares %2.0f px, gap %2.0f px, D %4.1f px: %d measured, %d flagged so far\n",
                  2 * h, g, diameter, measured, flagged);
    }
  // Flagging is not how the test passes: under blurs of 3.5 and 6 px 15 of 16 sides are
  // measured per layout (those facing across the gap jointly; one with a third edge in
  // between is flagged); sides 30 px long under 10 and 19 px blurs are too short to measure.
  EXPECT_GE(measured, flagged);
  EXPECT_EQ(wrong, 0);
}

}  // namespace
}  // namespace camlab::analysis
