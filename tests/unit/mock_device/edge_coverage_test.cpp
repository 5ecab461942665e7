// The renderer's straight-edge coverage (edge_coverage.h) against the geometry written out
// here: the circular segment by its textbook formula, antiderivatives by numerical
// integration, the pixel mean by brute-force averaging, and the aperture line by tracing
// rays from a grid of aperture points to a tilted plane.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "mock_device/render/edge_coverage.h"

namespace camlab::mock {
namespace {

constexpr double kPi = std::numbers::pi;

// Share of the unit disk on the centre's side of a chord at distance |h| from the centre
// (the other side when h < 0): 1 - segment / pi, the segment area acos(d) - d sqrt(1 - d^2).
double segment_share(double h) {
  if (h >= 1) return 1;
  if (h <= -1) return 0;
  const double d = std::fabs(h);
  const double segment = (std::acos(d) - d * std::sqrt(1 - d * d)) / kPi;
  return h >= 0 ? 1 - segment : segment;
}

// Simpson's rule over [a, b] with n (even) intervals.
template <class F>
double simpson(F f, double a, double b, int n) {
  const double step = (b - a) / n;
  double sum = f(a) + f(b);
  for (int i = 1; i < n; ++i) sum += (i % 2 ? 4 : 2) * f(a + i * step);
  return sum * step / 3;
}

TEST(EdgeCoverage, DiskCoverageIsTheCircularSegmentsComplement) {
  for (double h = -1.3; h <= 1.3; h += 0.01)
    EXPECT_NEAR(disk_coverage(h), segment_share(h), 1e-12) << "h = " << h;
}

TEST(EdgeCoverage, TheAntiderivativesIntegrateTheCoverage) {
  for (double t : {-1.5, -0.9, -0.3, 0.0, 0.4, 0.95, 1.0, 1.7, 4.0}) {
    const double c1 = simpson(segment_share, -2.0, t, 20000);
    EXPECT_NEAR(disk_coverage_integral(t), c1, 1e-9) << "t = " << t;
    const double c2 = simpson([](double x) { return disk_coverage_integral(x); }, -2.0, t, 20000);
    EXPECT_NEAR(disk_coverage_second_integral(t), c2, 1e-9) << "t = " << t;
  }
}

// The mean of segment_share(centre + a (x - 1/2) + b (y - 1/2)) over the unit square, on
// an n x n midpoint grid.
double brute_pixel_mean(double centre, double a, double b, int n) {
  double sum = 0;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const double x = (i + 0.5) / n - 0.5, y = (j + 0.5) / n - 0.5;
      sum += segment_share(centre + a * x + b * y);
    }
  return sum / (static_cast<double>(n) * n);
}

TEST(EdgeCoverage, PixelMeanIsTheAverageOverThePixel) {
  struct Case {
    double centre, a, b, tolerance;
  };
  // Blurred edges (h changes by less than the disk across the pixel), an edge along the
  // pixel grid (b = 0), a point (a = b = 0), and in focus (h changes by thousands: a step
  // whose grid average is good to about 1 / n).
  const Case cases[] = {{0.3, 0.5, 0.2, 1e-6},      {-0.7, 3.0, 1.0, 1e-6}, {0.9, -0.4, 0.7, 1e-6},
                        {0.2, 2.0, 0.0, 1e-6},      {0.45, 0.0, 0.0, 1e-9}, {0.1, 40.0, 25.0, 2e-4},
                        {-30.0, 400.0, 90.0, 2e-3}, {5e3, 2e5, 1e5, 2e-3}};
  for (const Case& c : cases) {
    const double want = brute_pixel_mean(c.centre, c.a, c.b, 1000);
    EXPECT_NEAR(pixel_mean_coverage(c.centre, c.a, c.b), want, c.tolerance)
        << c.centre << " " << c.a << " " << c.b;
  }
}

TEST(EdgeCoverage, PixelPositiveShareIsTheAreaOfThePixelPastTheLine) {
  // A line x + 0.5 y = 0.1 across the unit square centred at 0: the area with
  // x + 0.5 y > 0.1 by polygon geometry: the line meets y = -1/2 at x = 0.35 and y = 1/2
  // at x = -0.15, so the part past it is a trapezoid of mean width 1/2 - 0.1 = 0.4.
  EXPECT_NEAR(pixel_positive_share(-0.1, 1.0, 0.5), 0.4, 1e-12);
  EXPECT_NEAR(pixel_positive_share(-0.1e6, 1e6, 0.5e6), 0.4, 1e-9) << "scale-free";
  EXPECT_EQ(pixel_positive_share(2.0, 1.0, 1.0), 1.0);
  EXPECT_EQ(pixel_positive_share(-2.0, 1.0, 1.0), 0.0);
  EXPECT_NEAR(pixel_positive_share(0.2, 1.0, 0.0), 0.7, 1e-12);
}

// A tilted plane through (0.02, -0.01, 0.9) m with normal `n`, and an edge on it: the
// plane's points with e . X > k are the positive side. For a chief ray and a plane of focus
// at 1/q, the share of the aperture (radius r) whose rays hit the positive side, by tracing
// rays from an n x n grid of aperture points.
struct TiltedEdge {
  double n[3], c, e[3], k;
};

TiltedEdge tilted_edge() {
  // Normal: (0, 0, -1) turned 30 degrees about x and 10 about y; the edge's normal lies in
  // the plane, perpendicular to n (e = n x (1, 0.3, 0), normalised).
  const double ax = 30 * kPi / 180, ay = 10 * kPi / 180;
  double n[3] = {0, std::sin(ax), -std::cos(ax)};
  const double nx = n[0] * std::cos(ay) + n[2] * std::sin(ay);
  n[2] = -n[0] * std::sin(ay) + n[2] * std::cos(ay);
  n[0] = nx;
  const double p[3] = {0.02, -0.01, 0.9};
  const double dir[3] = {1, 0.3, 0};
  double e[3] = {n[1] * dir[2] - n[2] * dir[1], n[2] * dir[0] - n[0] * dir[2],
                 n[0] * dir[1] - n[1] * dir[0]};
  const double len = std::sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
  TiltedEdge t{};
  for (int i = 0; i < 3; ++i) {
    t.n[i] = n[i];
    t.e[i] = e[i] / len;
  }
  t.c = t.n[0] * p[0] + t.n[1] * p[1] + t.n[2] * p[2];
  t.k = t.e[0] * p[0] + t.e[1] * p[1] + t.e[2] * p[2] + 0.0004;  // 0.4 mm off the point
  return t;
}

double traced_share(const TiltedEdge& t, double xn, double yn, double r, double q, int n) {
  int inside = 0, positive = 0;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const double ox = ((i + 0.5) / n * 2 - 1) * r, oy = ((j + 0.5) / n * 2 - 1) * r;
      if (ox * ox + oy * oy > r * r) continue;
      ++inside;
      // The ray leaves (ox, oy, 0) along the chief ray, bent towards the plane of focus:
      // at depth z it is at z (xn, yn) + o (1 - z q).
      const double d[3] = {xn - ox * q, yn - oy * q, 1.0};
      const double lambda =
          (t.c - (t.n[0] * ox + t.n[1] * oy)) / (t.n[0] * d[0] + t.n[1] * d[1] + t.n[2] * d[2]);
      const double X[3] = {ox + lambda * d[0], oy + lambda * d[1], lambda * d[2]};
      if (t.e[0] * X[0] + t.e[1] * X[1] + t.e[2] * X[2] > t.k) ++positive;
    }
  return static_cast<double>(positive) / inside;
}

TEST(EdgeCoverage, TheApertureLineSplitsTheApertureAsTracedRaysDo) {
  const TiltedEdge t = tilted_edge();
  const EdgeInCamera edge = {{t.n[0], t.n[1], t.n[2]}, t.c, {t.e[0], t.e[1], t.e[2]}, t.k};
  const double r = 0.002;  // an 8 mm f/2 lens
  // Focused in front of the plane, behind it, at infinity, and beyond infinity.
  for (double q : {1 / 0.6, 1 / 1.4, 0.0, -1 / 3.0}) {
    int straddling = 0;
    for (double xn = 0.005; xn <= 0.045; xn += 0.0025)
      for (double yn = -0.02; yn <= 0.0; yn += 0.005) {
        const double h = aperture_edge_distance(edge, xn, yn, r, q);
        const double want = traced_share(t, xn, yn, r, q, 400);
        straddling += want > 0.02 && want < 0.98;
        EXPECT_NEAR(disk_coverage(h), want, 2e-3) << "q " << q << " at " << xn << ", " << yn;
      }
    EXPECT_GT(straddling, 3) << "some chief rays must see the edge through part of the aperture";
  }
}

TEST(EdgeCoverage, AFocusedPointIsOnOneSideOnly) {
  const TiltedEdge t = tilted_edge();
  const EdgeInCamera edge = {{t.n[0], t.n[1], t.n[2]}, t.c, {t.e[0], t.e[1], t.e[2]}, t.k};
  // A plane of focus through the plane's point on the chief ray: every aperture ray meets
  // the plane there, so the coverage is 0 or 1 (the aperture line, n_xy . o = c, lies far
  // outside the disk).
  for (double xn : {0.03, 0.012, 0.021}) {
    const double yn = -0.01;
    const double z = t.c / (t.n[0] * xn + t.n[1] * yn + t.n[2]);
    const double h = aperture_edge_distance(edge, xn, yn, 0.002, 1 / z);
    EXPECT_GT(std::fabs(h), 100.0);
    const double side = t.e[0] * z * xn + t.e[1] * z * yn + t.e[2] * z - t.k;
    EXPECT_EQ(disk_coverage(h), side > 0 ? 1.0 : 0.0);
  }
}

TEST(EdgeCoverage, PixelCoverageFromCornersFallsBackWhenTheLinearFormWouldBeWrong) {
  // h = 0.3 + 0.8 (x - 1/2) over the pixel: the corners say so exactly.
  EdgeTerms corners[4] = {{-0.1, 1.0}, {0.7, 1.0}, {-0.1, 1.0}, {0.7, 1.0}};
  EXPECT_NEAR(pixel_edge_coverage(corners, 5e-4), brute_pixel_mean(0.3, 0.8, 0.0, 400), 1e-5);
  // |w| doubling across the pixel: the linear form's error is far above the tolerance.
  EdgeTerms changing[4] = {{-0.1, 0.5}, {0.7, 1.0}, {-0.1, 0.5}, {0.7, 1.0}};
  EXPECT_TRUE(std::isnan(pixel_edge_coverage(changing, 5e-4)));
  // Whatever |w| does, a pixel whose every point has h >= 1 is covered.
  EdgeTerms far[4] = {{3.0, 0.5}, {4.0, 2.0}, {3.0, 0.5}, {4.0, 2.9}};
  EXPECT_EQ(pixel_edge_coverage(far, 5e-4), 1.0);
}

}  // namespace
}  // namespace camlab::mock
