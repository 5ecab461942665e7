#include "optics/aperture_cells.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <string>

namespace camlab::optics {

namespace {

// Gauss-Legendre nodes and weights on [-1, 1] (Newton on the Legendre polynomial): an
// n-point rule is exact for polynomials of degree 2n - 1 and converges exponentially for
// the smooth trigonometric integrands below.
constexpr int kGaussPoints = 16;
struct GaussLegendre {
  std::array<double, kGaussPoints> x{}, w{};
  GaussLegendre() {
    const int n = kGaussPoints;
    for (int i = 0; i < n; ++i) {
      double z = std::cos(std::numbers::pi * (i + 0.75) / (n + 0.5));
      double dp = 1;
      for (int iteration = 0; iteration < 100; ++iteration) {
        double p0 = 1, p1 = z;
        for (int k = 2; k <= n; ++k) {
          const double p2 = ((2 * k - 1) * z * p1 - (k - 1) * p0) / k;
          p0 = p1;
          p1 = p2;
        }
        dp = n * (z * p1 - p0) / (z * z - 1);
        const double step = p1 / dp;
        z -= step;
        if (std::fabs(step) < 1e-16) break;
      }
      x[static_cast<size_t>(i)] = z;
      w[static_cast<size_t>(i)] = 2 / ((1 - z * z) * dp * dp);
    }
  }
};

const GaussLegendre& gauss() {
  static const GaussLegendre rule;
  return rule;
}

// The moments of the unit disk inside [x0, x1] x [y0, y1]. For each x the region spans
// y in [max(y0, -s), min(y1, s)] with s = sqrt(1 - x^2); between the x where s meets |y0|
// or |y1| each bound is a constant or +-s, so with x = sin(theta) (s = cos(theta),
// dx = cos(theta) dtheta) every integrand is a smooth trigonometric polynomial.
RegionMoments unit_disk_rect_moments(double x0, double x1, double y0, double y1) {
  RegionMoments m;
  const double a = std::max(x0, -1.0), b = std::min(x1, 1.0);
  if (!(b > a) || !(y1 > y0) || y0 >= 1 || y1 <= -1) return m;
  std::vector<double> cuts = {a, b};
  for (double y : {y0, y1})
    if (std::fabs(y) < 1) {
      const double x = std::sqrt(1 - y * y);
      for (double c : {-x, x})
        if (c > a && c < b) cuts.push_back(c);
    }
  std::sort(cuts.begin(), cuts.end());
  const GaussLegendre& g = gauss();
  for (size_t k = 0; k + 1 < cuts.size(); ++k) {
    const double t0 = std::asin(std::clamp(cuts[k], -1.0, 1.0));
    const double t1 = std::asin(std::clamp(cuts[k + 1], -1.0, 1.0));
    if (!(t1 > t0)) continue;
    const double half = 0.5 * (t1 - t0), mid = 0.5 * (t1 + t0);
    for (int i = 0; i < kGaussPoints; ++i) {
      const double t = mid + half * g.x[static_cast<size_t>(i)];
      const double x = std::sin(t), s = std::cos(t);
      const double lo = std::max(y0, -s), hi = std::min(y1, s);
      if (hi <= lo) continue;
      const double w = g.w[static_cast<size_t>(i)] * half * s;  // dx = cos(theta) dtheta
      const double len = hi - lo;
      m.area += w * len;
      m.sum_x += w * x * len;
      m.sum_y += w * 0.5 * (hi * hi - lo * lo);
      m.sum_xx += w * x * x * len;
      m.sum_yy += w * (hi * hi * hi - lo * lo * lo) / 3;
    }
  }
  return m;
}

}  // namespace

RegionMoments disk_rect_moments(double x0, double x1, double y0, double y1, double radius) {
  if (!(radius > 0)) return {};
  RegionMoments m = unit_disk_rect_moments(x0 / radius, x1 / radius, y0 / radius, y1 / radius);
  const double r2 = radius * radius, r3 = r2 * radius, r4 = r2 * r2;
  m.area *= r2;
  m.sum_x *= r3;
  m.sum_y *= r3;
  m.sum_xx *= r4;
  m.sum_yy *= r4;
  return m;
}

Result<std::vector<ApertureCell>> aperture_cells(int views_u, int views_v) {
  for (auto [name, n] : {std::pair{"views_u", views_u}, std::pair{"views_v", views_v}})
    if (n < 1 || n > 64)
      return make_error("out_of_range", std::string(name) + " = " + std::to_string(n) +
                                            " is out of range [1, 64] (views per side)");
  std::vector<ApertureCell> cells;
  cells.reserve(static_cast<size_t>(views_u) * views_v);
  const double disk_area = std::numbers::pi;
  for (int j = 0; j < views_v; ++j)
    for (int i = 0; i < views_u; ++i) {
      ApertureCell c;
      c.u_index = i;
      c.v_index = j;
      c.x0 = -1 + 2.0 * i / views_u;
      c.x1 = -1 + 2.0 * (i + 1) / views_u;
      c.y0 = -1 + 2.0 * j / views_v;
      c.y1 = -1 + 2.0 * (j + 1) / views_v;
      const RegionMoments m = disk_rect_moments(c.x0, c.x1, c.y0, c.y1);
      c.area_share = std::min(1.0, m.area / disk_area);  // the whole disk: 1, not 1 + 2e-16
      c.lit_share = std::min(1.0, m.area / ((c.x1 - c.x0) * (c.y1 - c.y0)));
      if (m.area > 0) {
        c.centroid_x = m.sum_x / m.area;
        c.centroid_y = m.sum_y / m.area;
        c.mean_xx = m.sum_xx / m.area;
        c.mean_yy = m.sum_yy / m.area;
      }
      cells.push_back(c);
    }
  return cells;
}

}  // namespace camlab::optics
