// The edge finder on edges drawn independently (analytic_edge.h): one slanted edge blurred
// by 10..45 px is found once (a wide blur's gradient leaves gaps and parallel ridges that
// used to split it in two), while the two edges of a bar and two collinear edges with flat
// image between them stay two.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "analysis/edge/edge_finder.h"
#include "analytic_edge.h"

namespace camlab::analysis {
namespace {

constexpr int kSize = 400;
const double kCentre = (kSize - 1) / 2.0;
const double kAngle = 5.0 * std::numbers::pi / 180.0;
const double kNx = std::cos(kAngle), kNy = -std::sin(kAngle);

// `light(d, y)`: the light fraction of a pixel at signed distance d from the edge line.
template <class Light>
cv::Mat draw(Light light) {
  std::mt19937 rng(1);
  std::normal_distribution<double> noise(0, 3);
  cv::Mat image(kSize, kSize, CV_16UC1);
  for (int y = 0; y < kSize; ++y)
    for (int x = 0; x < kSize; ++x) {
      const double d = (x - kCentre) * kNx + (y - kCentre) * kNy;
      image.at<uint16_t>(y, x) =
          static_cast<uint16_t>(std::lround(200 + 2000 * light(d, y) + noise(rng)));
    }
  return image;
}

TEST(EdgeFinderWide, OneEdgeBlurredByTensOfPixelsIsFoundOnce) {
  for (double diameter : {10.0, 20.0, 30.0, 37.5, 45.0}) {
    const auto edges = find_edges(draw([&](double d, int) {
                                    return testing::pixel_light_fraction(d, diameter, kNx, kNy, 4);
                                  }),
                                  {});
    ASSERT_EQ(edges.size(), 1u) << "D = " << diameter << " px";
    EXPECT_GT(std::hypot(edges[0].end_x_px - edges[0].start_x_px,
                         edges[0].end_y_px - edges[0].start_y_px),
              300)
        << "D = " << diameter << ": the pieces were joined";
  }
}

// Signed distance of an edge segment's midpoint from the line d = offset.
double midpoint_offset(const EdgeSegment& e, double offset) {
  const double mx = 0.5 * (e.start_x_px + e.end_x_px), my = 0.5 * (e.start_y_px + e.end_y_px);
  return (mx - kCentre) * kNx + (my - kCentre) * kNy - offset;
}

TEST(EdgeFinderWide, ABarsTwoEdgesAndCollinearEdgesWithAFlatGapAreNotJoined) {
  const double diameter = 10;
  const auto bar =
      find_edges(draw([&](double d, int) {  // light between d = -30 and +30
                   return testing::pixel_light_fraction(d + 30, diameter, kNx, kNy, 4) -
                          testing::pixel_light_fraction(d - 30, diameter, kNx, kNy, 4);
                 }),
                 {});
  bool left = false, right = false;
  for (const auto& e : bar) {
    left |= std::fabs(midpoint_offset(e, -30)) < 5;  // found segments are within a few px
    right |= std::fabs(midpoint_offset(e, 30)) < 5;
  }
  EXPECT_TRUE(left && right) << "both edges of the bar, 60 px apart, are found";
  // The slanted edge only above y = 150 and below y = 250, flat dark between: no found
  // segment on that line may bridge the flat part.
  const auto collinear =
      find_edges(draw([&](double d, int y) {
                   if (y > 150 && y < 250) return 0.0;
                   return testing::pixel_light_fraction(d, diameter, kNx, kNy, 4);
                 }),
                 {});
  int on_line = 0;
  for (const auto& e : collinear) {
    if (std::fabs(midpoint_offset(e, 0)) > 5) continue;  // the light area's other borders
    ++on_line;
    const double top = std::min(e.start_y_px, e.end_y_px),
                 bottom = std::max(e.start_y_px, e.end_y_px);
    EXPECT_FALSE(top < 160 && bottom > 240) << "a segment bridges the flat gap";
  }
  EXPECT_GE(on_line, 2);
}

}  // namespace
}  // namespace camlab::analysis
