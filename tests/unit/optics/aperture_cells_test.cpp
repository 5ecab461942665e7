// The aperture grid of a light field: cell areas and moments against the disk's own
// (closed forms) and against a brute-force count of points, independent of the
// theta-substitution quadrature the code uses.
#include <cmath>
#include <numbers>
#include <random>

#include <gtest/gtest.h>

#include "optics/aperture_cells.h"

namespace camlab::optics {
namespace {

// Area and moments of the unit disk inside a rectangle by a midpoint grid of n x n points.
RegionMoments brute_force(double x0, double x1, double y0, double y1, int n) {
  RegionMoments m;
  const double dx = (x1 - x0) / n, dy = (y1 - y0) / n;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const double x = x0 + (i + 0.5) * dx, y = y0 + (j + 0.5) * dy;
      if (x * x + y * y > 1) continue;
      const double a = dx * dy;
      m.area += a;
      m.sum_x += a * x;
      m.sum_y += a * y;
      m.sum_xx += a * x * x;
      m.sum_yy += a * y * y;
    }
  return m;
}

TEST(ApertureCells, WholeDiskHasItsClosedFormMoments) {
  // The disk of radius r: area pi r^2, integral of x^2 = pi r^4 / 4.
  for (double r : {1.0, 0.37, 2.5}) {
    const RegionMoments m = disk_rect_moments(-3, 3, -3, 3, r);
    EXPECT_NEAR(m.area, std::numbers::pi * r * r, 1e-12 * r * r);
    EXPECT_NEAR(m.sum_xx, std::numbers::pi * std::pow(r, 4) / 4, 1e-12 * std::pow(r, 4));
    EXPECT_NEAR(m.sum_yy, std::numbers::pi * std::pow(r, 4) / 4, 1e-12 * std::pow(r, 4));
    EXPECT_NEAR(m.sum_x, 0, 1e-12);
    // A quarter: the centroid of a quadrant is at 4 r / (3 pi) on each axis.
    const RegionMoments q = disk_rect_moments(0, r, 0, r, r);
    EXPECT_NEAR(q.centroid_x(), 4 * r / (3 * std::numbers::pi), 1e-12 * r);
    EXPECT_NEAR(q.centroid_y(), 4 * r / (3 * std::numbers::pi), 1e-12 * r);
  }
}

TEST(ApertureCells, RectanglesAgreeWithABruteForceCount) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> corner(-1.2, 1.2);
  for (int trial = 0; trial < 40; ++trial) {
    double x0 = corner(rng), x1 = corner(rng), y0 = corner(rng), y1 = corner(rng);
    if (x1 < x0) std::swap(x0, x1);
    if (y1 < y0) std::swap(y0, y1);
    const RegionMoments m = disk_rect_moments(x0, x1, y0, y1);
    const RegionMoments b = brute_force(x0, x1, y0, y1, 1500);
    // The grid's error is that of the circle's staircase: about the rectangle's side / n.
    EXPECT_NEAR(m.area, b.area, 2e-3) << x0 << " " << x1 << " " << y0 << " " << y1;
    EXPECT_NEAR(m.sum_x, b.sum_x, 2e-3);
    EXPECT_NEAR(m.sum_yy, b.sum_yy, 2e-3);
  }
}

TEST(ApertureCells, GridTilesTheDisk) {
  for (auto [u, v] : {std::pair{1, 1}, std::pair{2, 2}, std::pair{5, 5}, std::pair{9, 9},
                      std::pair{10, 10}, std::pair{7, 4}}) {
    auto cells = aperture_cells(u, v);
    ASSERT_TRUE(cells.ok());
    ASSERT_EQ(cells->size(), static_cast<size_t>(u * v));
    double share = 0, mx = 0, mxx = 0;
    for (const ApertureCell& c : *cells) {
      share += c.area_share;
      mx += c.area_share * c.centroid_x;
      mxx += c.area_share * c.mean_xx;
      EXPECT_GE(c.lit_share, 0);
      EXPECT_LE(c.lit_share, 1);
      // A cell and its mirror image have mirrored centroids.
      const ApertureCell& m =
          (*cells)[static_cast<size_t>((v - 1 - c.v_index) * u + (u - 1 - c.u_index))];
      EXPECT_NEAR(m.centroid_x, -c.centroid_x, 1e-12);
      EXPECT_NEAR(m.area_share, c.area_share, 1e-12);
    }
    EXPECT_NEAR(share, 1, 1e-12) << u << "x" << v;
    EXPECT_NEAR(mx, 0, 1e-12);
    EXPECT_NEAR(mxx, 0.25, 1e-12);  // the disk's mean x^2
  }
  // 9 x 9: the corner cells miss the disk, the centre cell is a whole square.
  auto cells = aperture_cells(9, 9);
  EXPECT_EQ((*cells)[0].area_share, 0);
  EXPECT_EQ((*cells)[40].lit_share, 1);
  EXPECT_NEAR((*cells)[40].area_share, (2.0 / 9) * (2.0 / 9) / std::numbers::pi, 1e-14);
}

TEST(ApertureCells, RefusesGridsOutOfRange) {
  for (auto [u, v] : {std::pair{0, 3}, std::pair{3, 65}, std::pair{-1, -1}}) {
    auto cells = aperture_cells(u, v);
    ASSERT_FALSE(cells.ok());
    EXPECT_EQ(cells.error().code, ErrorCode::kOutOfRange);
    EXPECT_NE(cells.error().message.find("[1, 64]"), std::string::npos);
  }
}

}  // namespace
}  // namespace camlab::optics
