#include "mock_device/render/aperture_region.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "mock_device/render/edge_coverage.h"
#include "mock_device/render/gauss_legendre.h"
#include "optics/aperture_cells.h"

namespace camlab::mock {

namespace {

using Vec = std::array<double, 2>;

double cross(const Vec& a, const Vec& b) { return a[0] * b[1] - a[1] * b[0]; }
double dot(const Vec& a, const Vec& b) { return a[0] * b[0] + a[1] * b[1]; }

// Signed area of the unit disk inside the triangle (0, a, b): the parts of segment ab
// inside the circle span triangles, the parts outside span circular sectors.
double triangle_in_disk(const Vec& a, const Vec& b) {
  const auto sector = [](const Vec& u, const Vec& v) {
    return 0.5 * std::atan2(cross(u, v), dot(u, v));
  };
  const Vec d = {b[0] - a[0], b[1] - a[1]};
  const double dd = dot(d, d), ad = dot(a, d), aa = dot(a, a);
  if (aa <= 1 && dot(b, b) <= 1) return 0.5 * cross(a, b);
  if (dd <= 0) return 0;
  const double disc = ad * ad - dd * (aa - 1);
  if (disc <= 0) return sector(a, b);
  const double root = std::sqrt(disc);
  const double t1 = (-ad - root) / dd, t2 = (-ad + root) / dd;
  if (t2 <= 0 || t1 >= 1) return sector(a, b);
  const double s1 = std::max(t1, 0.0), s2 = std::min(t2, 1.0);
  const Vec p1 = {a[0] + s1 * d[0], a[1] + s1 * d[1]};
  const Vec p2 = {a[0] + s2 * d[0], a[1] + s2 * d[1]};
  return sector(a, p1) + 0.5 * cross(p1, p2) + sector(p2, b);
}

// The convex polygon `in` (counter-clockwise, n vertices) clipped to dir . p + h > 0.
int clip(const Vec* in, int n, double h, double dir_x, double dir_y, Vec* out) {
  int m = 0;
  for (int i = 0; i < n; ++i) {
    const Vec& p = in[i];
    const Vec& q = in[(i + 1) % n];
    const double fp = dir_x * p[0] + dir_y * p[1] + h, fq = dir_x * q[0] + dir_y * q[1] + h;
    if (fp > 0) out[m++] = p;
    if ((fp > 0) != (fq > 0)) {
      const double t = fp / (fp - fq);
      out[m++] = {p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])};
    }
  }
  return m;
}

// The density of h over a pixel on which h is linear (h - centre is the sum of two
// uniform variables of widths a >= b): a trapezoid with corners t1 .. t4.
struct Trapezoid {
  double a, b, t1, t2, t3, t4;
  double density(double t) const {
    if (t <= t1 || t >= t4) return 0;
    if (b < 1e-9 * a) return 1 / a;
    const auto ramp = [](double x) { return x > 0 ? x : 0.0; };
    return (ramp(t - t1) - ramp(t - t2) - ramp(t - t3) + ramp(t - t4)) / (a * b);
  }
};

}  // namespace

ApertureRegion::ApertureRegion(double x0, double x1, double y0, double y1)
    : x0_(x0), x1_(x1), y0_(y0), y1_(y1) {
  xa_ = std::max(x0, -1.0);
  xb_ = std::min(x1, 1.0);
  const optics::RegionMoments m = optics::disk_rect_moments(x0, x1, y0, y1);
  area_ = m.area;
  if (area_ <= 1e-15) {
    area_ = 0;
    return;
  }
  centroid_ = {m.centroid_x(), m.centroid_y()};
  const Vec corners[4] = {{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}};
  inside_disk_ = true;
  for (const Vec& c : corners) {
    if (dot(c, c) <= 1)
      vertices_.push_back(c);
    else
      inside_disk_ = false;
  }
  for (double x : {x0, x1})
    if (std::fabs(x) < 1)
      for (double y : {-std::sqrt(1 - x * x), std::sqrt(1 - x * x)})
        if (y > y0 && y < y1) vertices_.push_back({x, y});
  for (double y : {y0, y1})
    if (std::fabs(y) < 1)
      for (double x : {-std::sqrt(1 - y * y), std::sqrt(1 - y * y)})
        if (x > x0 && x < x1) vertices_.push_back({x, y});
  // The coverage's derivative in h is the region's chord along the line over its area;
  // no chord and no range of h exceeds the bounding box's diagonal.
  const double diagonal = std::hypot(xb_ - xa_, std::min(y1, 1.0) - std::max(y0, -1.0));
  max_slope_ = diagonal / area_;
  span_ = diagonal;

  // The cubature rules: Gauss in x over each piece between the x where the circle meets
  // y0 or y1 (in theta = asin x where a piece reaches |x| = 1, where the bounds have a
  // square-root end), Gauss in y between the bounds.
  std::vector<double> cuts = {xa_, xb_};
  for (double y : {y0, y1})
    if (std::fabs(y) < 1)
      for (double x : {-std::sqrt(1 - y * y), std::sqrt(1 - y * y)})
        if (x > xa_ && x < xb_) cuts.push_back(x);
  std::sort(cuts.begin(), cuts.end());
  for (int order = 1; order <= 4; ++order) {
    const GaussRule& g = kGauss[order];
    std::vector<Point>& rule = rules_[static_cast<size_t>(order)];
    for (size_t k = 0; k + 1 < cuts.size(); ++k) {
      const double a = cuts[k], b = cuts[k + 1];
      if (!(b > a)) continue;
      const bool at_rim = a <= -1 + 1e-12 || b >= 1 - 1e-12;
      const double ta = at_rim ? std::asin(std::clamp(a, -1.0, 1.0)) : a;
      const double tb = at_rim ? std::asin(std::clamp(b, -1.0, 1.0)) : b;
      // In theta the bounds are trigonometric: pieces of at most 0.4 rad keep a 4-point
      // rule within 1e-4 of the region's moments (one piece for the rim cells of a fine
      // grid, eight for the whole disk).
      const int parts = at_rim ? std::max(1, static_cast<int>(std::ceil((tb - ta) / 0.4))) : 1;
      for (int part = 0; part < parts; ++part) {
        const double pa = ta + (tb - ta) * part / parts, pb = ta + (tb - ta) * (part + 1) / parts;
        for (int i = 0; i < g.n; ++i) {
          const double t = pa + (pb - pa) * g.x[i];
          const double x = at_rim ? std::sin(t) : t;
          const double dx = (pb - pa) * g.w[i] * (at_rim ? std::cos(t) : 1.0);
          double lo, hi;
          bounds_at(x, &lo, &hi);
          if (!(hi > lo)) continue;
          for (int j = 0; j < g.n; ++j)
            rule.push_back({x, lo + (hi - lo) * g.x[j], dx * (hi - lo) * g.w[j] / area_});
        }
      }
    }
    // The weights are exact in x and y up to the rule's order; scale them to sum to 1
    // so that a constant is integrated exactly.
    double sum = 0;
    for (const Point& p : rule) sum += p.w;
    for (Point& p : rule) p.w /= sum;
  }
}

void ApertureRegion::bounds_at(double x, double* lo, double* hi) const {
  const double s = std::sqrt(std::max(0.0, 1 - x * x));
  *lo = std::max(y0_, -s);
  *hi = std::min(y1_, s);
}

double ApertureRegion::area_positive(double h, double dir_x, double dir_y) const {
  const Vec rect[4] = {{x0_, y0_}, {x1_, y0_}, {x1_, y1_}, {x0_, y1_}};
  Vec poly[8];
  const int n = clip(rect, 4, h, dir_x, dir_y, poly);
  double area = 0;
  for (int i = 0; i < n; ++i)
    area += inside_disk_ ? 0.5 * cross(poly[i], poly[(i + 1) % n])
                         : triangle_in_disk(poly[i], poly[(i + 1) % n]);
  return area;
}

double ApertureRegion::coverage(double h, double dir_x, double dir_y) const {
  if (empty()) return 0;
  return std::clamp(area_positive(h, dir_x, dir_y) / area_, 0.0, 1.0);
}

double ApertureRegion::pixel_mean_coverage(double h_centre, double slope_a, double slope_b,
                                           double dir_x, double dir_y) const {
  if (empty()) return 0;
  // The h below which no point of the region is on the positive side, and above which
  // every point is: at the region's extremes along dir (vertices, or the circle's point
  // in direction +-dir where that lies in the rectangle).
  std::vector<double> breaks;
  breaks.reserve(vertices_.size() + 8);
  for (const Vec& v : vertices_) breaks.push_back(-(dir_x * v[0] + dir_y * v[1]));
  for (double sign : {-1.0, 1.0}) {
    const double px = sign * dir_x, py = sign * dir_y;
    if (px >= x0_ && px <= x1_ && py >= y0_ && py <= y1_) breaks.push_back(-sign);
  }
  const auto [lo_it, hi_it] = std::minmax_element(breaks.begin(), breaks.end());
  const double h_lo = *lo_it, h_hi = *hi_it;

  double a = std::fabs(slope_a), b = std::fabs(slope_b);
  if (a < b) std::swap(a, b);
  const Trapezoid tz{a,
                     b,
                     h_centre - 0.5 * (a + b),
                     h_centre - 0.5 * (a - b),
                     h_centre + 0.5 * (a - b),
                     h_centre + 0.5 * (a + b)};
  if (tz.t4 <= h_lo) return 0;
  if (tz.t1 >= h_hi) return 1;
  if (a <= 1e-12) return coverage(h_centre, dir_x, dir_y);
  // In focus the region is a speck against the spread of h: its coverage is a step at
  // the mean of -dir . p, and the error of that is second order in the ratio.
  if (a > 1e4 * (h_hi - h_lo))
    return pixel_positive_share(h_centre + dir_x * centroid_[0] + dir_y * centroid_[1], slope_a,
                                slope_b);
  const double from = std::max(tz.t1, h_lo), to = std::min(tz.t4, h_hi);
  breaks.push_back(tz.t2);
  breaks.push_back(tz.t3);
  breaks.push_back(from);
  breaks.push_back(to);
  std::sort(breaks.begin(), breaks.end());
  // Pieces longer than half the disk's radius in h are halved until they are not: the
  // coverage is analytic inside a piece, but near the rim its radius of convergence is
  // short (within 3e-5 of the whole disk's closed form at 0.5, 4e-6 at 0.25).
  for (size_t k = 0; k + 1 < breaks.size(); ++k)
    if (breaks[k + 1] - breaks[k] > 0.25) {
      breaks.insert(breaks.begin() + static_cast<std::ptrdiff_t>(k) + 1,
                    0.5 * (breaks[k] + breaks[k + 1]));
      --k;
    }
  const GaussRule& g = kGauss[4];
  double sum = 0;
  for (size_t k = 0; k + 1 < breaks.size(); ++k) {
    const double p = std::max(breaks[k], from), q = std::min(breaks[k + 1], to);
    if (!(q > p)) continue;
    // Where a line grazes the circle (h = -+1) the coverage goes as a power 3/2 of the
    // distance: t = p + (q - p) s^2 from that end makes the integrand smooth in s.
    const bool graze_p = std::fabs(std::fabs(p) - 1) < 1e-12;
    const bool graze_q = std::fabs(std::fabs(q) - 1) < 1e-12;
    for (int i = 0; i < g.n; ++i) {
      double t, jacobian;
      if (graze_p && !graze_q) {
        t = p + (q - p) * g.x[i] * g.x[i];
        jacobian = 2 * (q - p) * g.x[i];
      } else if (graze_q && !graze_p) {
        t = q - (q - p) * g.x[i] * g.x[i];
        jacobian = 2 * (q - p) * g.x[i];
      } else {
        t = p + (q - p) * g.x[i];
        jacobian = q - p;
      }
      sum += jacobian * g.w[i] * coverage(t, dir_x, dir_y) * tz.density(t);
    }
  }
  // Where h is above the region's range its coverage is 1.
  sum += pixel_positive_share(h_centre - h_hi, slope_a, slope_b);
  return std::clamp(sum, 0.0, 1.0);
}

void ApertureRegion::sample(double a, double b, double* x, double* y, double* weight) const {
  *x = xa_ + a * (xb_ - xa_);
  double lo, hi;
  bounds_at(*x, &lo, &hi);
  if (!(hi > lo)) {
    *y = centroid_[1];
    *weight = 0;
    return;
  }
  *y = lo + b * (hi - lo);
  *weight = (hi - lo) * (xb_ - xa_) / area_;
}

}  // namespace camlab::mock
