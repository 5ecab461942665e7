// One sub-aperture of a light field as the renderer integrates over it: the exact share
// of a cell on one side of a line, its mean over a pixel, the cubature rule and the
// sampling map, each against a brute-force count of points or the whole disk's closed
// forms (edge_coverage.h), written independently of aperture_region.cpp.
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "mock_device/render/aperture_region.h"
#include "mock_device/render/edge_coverage.h"
#include "optics/aperture_cells.h"

namespace camlab::mock {
namespace {

// Share of the region (unit disk inside the rectangle) where dx x + dy y + h > 0, by a
// midpoint grid of n x n points.
double counted_coverage(double x0, double x1, double y0, double y1, double h, double dx, double dy,
                        int n) {
  long inside = 0, positive = 0;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const double x = x0 + (i + 0.5) * (x1 - x0) / n, y = y0 + (j + 0.5) * (y1 - y0) / n;
      if (x * x + y * y > 1) continue;
      ++inside;
      positive += dx * x + dy * y + h > 0;
    }
  return inside ? static_cast<double>(positive) / inside : 0;
}

struct Cell {
  double x0, x1, y0, y1;
};
// Whole squares inside the disk, squares cut by its rim, a sliver, the whole disk.
const Cell kCells[] = {{-0.2, 0.2, -0.2, 0.2},       {0.6, 1.0, 0.2, 0.6},
                       {-1.0, -0.6, -0.2, 0.2},      {0.555, 0.777, 0.555, 0.777},
                       {-1.0, -0.777, 0.333, 0.555}, {-1, 1, -1, 1}};

TEST(ApertureRegion, CoverageMatchesACountOfPoints) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> angle(0, 2 * M_PI), offset(-1.2, 1.2);
  for (const Cell& c : kCells) {
    const ApertureRegion region(c.x0, c.x1, c.y0, c.y1);
    ASSERT_FALSE(region.empty());
    for (int trial = 0; trial < 25; ++trial) {
      const double a = angle(rng), h = offset(rng);
      const double expected =
          counted_coverage(c.x0, c.x1, c.y0, c.y1, h, std::cos(a), std::sin(a), 800);
      EXPECT_NEAR(region.coverage(h, std::cos(a), std::sin(a)), expected, 4e-3)
          << c.x0 << " " << c.y0 << " h " << h << " angle " << a;
    }
  }
}

TEST(ApertureRegion, WholeDiskIsTheCircularSegment) {
  const ApertureRegion disk(-1, 1, -1, 1);
  EXPECT_NEAR(disk.area(), M_PI, 1e-12);
  for (double h = -1.2; h <= 1.2; h += 0.05)
    for (double a : {0.0, 0.7, 2.0, 4.0})
      EXPECT_NEAR(disk.coverage(h, std::cos(a), std::sin(a)), disk_coverage(h), 1e-12) << h;
  // Over a pixel: the same as the disk's closed form in its second antiderivative, far
  // within the renderer's 5e-4 (its integral is piecewise Gauss, the disk's exact).
  for (double centre : {-1.3, -0.5, 0.0, 0.3, 0.95})
    for (auto [sa, sb] :
         {std::pair{0.4, 0.1}, std::pair{2.0, 1.5}, std::pair{0.05, 0.0}, std::pair{30.0, 7.0}})
      EXPECT_NEAR(disk.pixel_mean_coverage(centre, sa, sb, 1, 0),
                  pixel_mean_coverage(centre, sa, sb), 1e-5)
          << centre << " " << sa << " " << sb;
}

TEST(ApertureRegion, PixelMeanMatchesAnAverageOverThePixel) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> angle(0, 2 * M_PI), centre(-1.0, 1.0), slope(-3.0, 3.0);
  for (const Cell& c : kCells) {
    const ApertureRegion region(c.x0, c.x1, c.y0, c.y1);
    for (int trial = 0; trial < 12; ++trial) {
      const double a = angle(rng), hc = centre(rng), sa = slope(rng), sb = slope(rng) / 4;
      // The pixel's own average: h linear over a 400 x 400 grid of the unit pixel.
      const int n = 400;
      double sum = 0;
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
          const double h = hc + sa * ((i + 0.5) / n - 0.5) + sb * ((j + 0.5) / n - 0.5);
          sum += region.coverage(h, std::cos(a), std::sin(a));
        }
      EXPECT_NEAR(region.pixel_mean_coverage(hc, sa, sb, std::cos(a), std::sin(a)), sum / (n * n),
                  2e-4)
          << c.x0 << " " << c.y0 << " centre " << hc << " slopes " << sa << " " << sb;
    }
  }
}

TEST(ApertureRegion, RulesIntegrateTheRegionsMoments) {
  for (const Cell& c : kCells) {
    const ApertureRegion region(c.x0, c.x1, c.y0, c.y1);
    const optics::RegionMoments m = optics::disk_rect_moments(c.x0, c.x1, c.y0, c.y1);
    for (int order = 1; order <= 4; ++order) {
      double w = 0, x = 0, xx = 0;
      for (const auto& p : region.rule(order)) {
        w += p.w;
        x += p.w * p.x;
        xx += p.w * p.x * p.x;
        ASSERT_LE(p.x * p.x + p.y * p.y, 1 + 1e-12);
      }
      EXPECT_NEAR(w, 1, 1e-12);
      // The rules converge quickly on the region's smooth moments.
      const double tolerance = order == 1 ? 5e-2 : order == 2 ? 5e-3 : order == 3 ? 3e-4 : 1e-4;
      EXPECT_NEAR(x, m.centroid_x(), tolerance) << "order " << order << " cell " << c.x0;
      EXPECT_NEAR(xx, m.sum_xx / m.area, tolerance) << "order " << order << " cell " << c.x0;
    }
    EXPECT_NEAR(region.centroid_x(), m.centroid_x(), 1e-12);
  }
}

TEST(ApertureRegion, SamplesAreUnbiased) {
  for (const Cell& c : kCells) {
    const ApertureRegion region(c.x0, c.x1, c.y0, c.y1);
    const int n = 300;
    double w = 0, x = 0, y = 0;
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        double px, py, weight;
        region.sample((i + 0.5) / n, (j + 0.5) / n, &px, &py, &weight);
        if (weight > 0) {
          ASSERT_LE(px * px + py * py, 1 + 1e-12);
        }
        w += weight;
        x += weight * px;
        y += weight * py;
      }
    EXPECT_NEAR(w / (n * n), 1, 2e-3) << c.x0;
    EXPECT_NEAR(x / w, region.centroid_x(), 2e-3) << c.x0;
    EXPECT_NEAR(y / w, region.centroid_y(), 2e-3) << c.x0;
  }
  EXPECT_TRUE(ApertureRegion(0.8, 1.0, 0.8, 1.0).empty());  // beyond the rim
}

}  // namespace
}  // namespace camlab::mock
