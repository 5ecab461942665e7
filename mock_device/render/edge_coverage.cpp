#include "mock_device/render/edge_coverage.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <utility>

namespace camlab::mock {

namespace {

constexpr double kInvPi = 1.0 / std::numbers::pi;

// The second antiderivative of a unit step at 0.
double ramp_second_integral(double t) { return t > 0 ? 0.5 * t * t : 0.0; }

// Sorted slopes and the trapezoid's corner positions: over a pixel on which h is linear,
// h - h_centre is the sum of two uniform variables of widths |a| and |b|, whose density is
// a trapezoid with corners h_centre -+ (A + B) / 2 and h_centre -+ (A - B) / 2 (A >= B).
struct Trapezoid {
  double a, b;            // A >= B >= 0
  double t1, t2, t3, t4;  // corner positions, ascending
};

Trapezoid trapezoid(double centre, double slope_a, double slope_b) {
  double a = std::fabs(slope_a), b = std::fabs(slope_b);
  if (a < b) std::swap(a, b);
  const double s = 0.5 * (a + b), d = 0.5 * (a - b);
  return {a, b, centre - s, centre - d, centre + d, centre + s};
}

}  // namespace

double disk_coverage(double h) {
  if (h <= -1) return 0;
  if (h >= 1) return 1;
  return 0.5 + (h * std::sqrt(1 - h * h) + std::asin(h)) * kInvPi;
}

double disk_coverage_integral(double h) {
  if (h <= -1) return 0;
  if (h >= 1) return h;
  const double r = std::sqrt(1 - h * h);
  return 0.5 * h + (h * std::asin(h) + r - r * r * r / 3) * kInvPi;
}

double disk_coverage_second_integral(double h) {
  if (h <= -1) return 0;
  if (h >= 1) return 0.5 * h * h + 0.125;
  const double r = std::sqrt(1 - h * h), as = std::asin(h);
  // The antiderivatives of (1 - h^2)^{3/2}, h asin h and sqrt(1 - h^2) (P, Q, S of
  // docs/virtual-camera.md).
  const double p = 0.25 * h * r * r * r + 0.375 * (h * r + as);
  const double q = 0.5 * h * h * as - 0.25 * (as - h * r);
  const double s = 0.5 * (h * r + as);
  return 0.25 * h * h + (q + s - p / 3) * kInvPi + 0.0625;
}

double pixel_mean_coverage(double h_centre, double slope_a, double slope_b) {
  const Trapezoid t = trapezoid(h_centre, slope_a, slope_b);
  if (t.t1 >= 1) return 1;
  if (t.t4 <= -1) return 0;
  // In focus: the disk is a speck against the pixel.
  if (t.a > 1e4) return pixel_positive_share(h_centre, slope_a, slope_b);
  if (t.a < 1e-9) return disk_coverage(h_centre);
  double value;
  if (t.b < 1e-7 * t.a) {
    // h changes in one direction only: the mean of C over [t1, t4].
    value = (disk_coverage_integral(t.t4) - disk_coverage_integral(t.t1)) / t.a;
  } else {
    value = (disk_coverage_second_integral(t.t4) - disk_coverage_second_integral(t.t3) -
             disk_coverage_second_integral(t.t2) + disk_coverage_second_integral(t.t1)) /
            (t.a * t.b);
  }
  return std::clamp(value, 0.0, 1.0);
}

double pixel_positive_share(double centre, double slope_a, double slope_b) {
  Trapezoid t = trapezoid(centre, slope_a, slope_b);
  if (t.t1 >= 0) return 1;
  if (t.t4 <= 0) return 0;
  // The step is scale-free: rescale so that the larger slope is 1 (no large numbers).
  const double scale = 1 / t.a;
  t = trapezoid(centre * scale, slope_a * scale, slope_b * scale);
  double value;
  if (t.b < 1e-9) {
    value = 0.5 + centre * scale;  // uniform over [c - 1/2, c + 1/2]
  } else {
    value = (ramp_second_integral(t.t4) - ramp_second_integral(t.t3) - ramp_second_integral(t.t2) +
             ramp_second_integral(t.t1)) /
            (t.a * t.b);
  }
  return std::clamp(value, 0.0, 1.0);
}

EdgeTerms aperture_edge_terms(const EdgeInCamera& edge, double xn, double yn,
                              double aperture_radius_m, double inverse_focus_m) {
  const double* n = edge.n;
  const double* e = edge.e;
  const double q = inverse_focus_m;
  const double d0 = n[0] * xn + n[1] * yn + n[2];  // n . c'
  const double ec = e[0] * xn + e[1] * yn + e[2];  // E . c'
  const double f = d0 - edge.c * q, g = edge.k * q - ec;
  const double wx = f * e[0] + g * n[0];
  const double wy = f * e[1] + g * n[1];
  const double w0 = edge.c * ec - edge.k * d0;
  const double w = std::sqrt(wx * wx + wy * wy);
  EdgeTerms t{edge.c > 0 ? w0 : -w0, w * aperture_radius_m};
  if (w > 0) {
    const double s = edge.c > 0 ? 1 / w : -1 / w;
    t.dir_x = wx * s;
    t.dir_y = wy * s;
  }
  return t;
}

double aperture_edge_distance(const EdgeInCamera& edge, double xn, double yn,
                              double aperture_radius_m, double inverse_focus_m, double* w_norm) {
  const EdgeTerms t = aperture_edge_terms(edge, xn, yn, aperture_radius_m, inverse_focus_m);
  if (w_norm) *w_norm = t.w_norm;
  if (t.w_norm == 0) return t.signed_w0 > 0 ? 1e300 : t.signed_w0 < 0 ? -1e300 : 0;
  return t.signed_w0 / t.w_norm;
}

PixelH pixel_h(const EdgeTerms corners[4]) {
  PixelH p;
  // Inside the pixel w0 and w are bilinear in the corners' (convex weights), so
  // sign(c) w0 >= its smallest corner value and |w| R <= its largest: a pixel whose every
  // point has h >= 1 (or <= -1) is on one side entirely, exactly.
  double s_min = corners[0].signed_w0, s_max = s_min, w_mean = 0, w_max = 0;
  for (int i = 0; i < 4; ++i) {
    s_min = std::min(s_min, corners[i].signed_w0);
    s_max = std::max(s_max, corners[i].signed_w0);
    w_mean += 0.25 * corners[i].w_norm;
    w_max = std::max(w_max, corners[i].w_norm);
  }
  if (s_min >= w_max && s_min > 0) {
    p.side = PixelH::kPositive;
    return p;
  }
  if (s_max <= -w_max && s_max < 0) {
    p.side = PixelH::kNegative;
    return p;
  }
  // h over the pixel as h_centre + a (alpha - 1/2) + b (beta - 1/2) + t (alpha - 1/2)
  // (beta - 1/2) from the corners; the linear part is integrated exactly, the twist t and
  // the change of |w| over the pixel are the approximation.
  const double s00 = corners[0].signed_w0, s10 = corners[1].signed_w0, s01 = corners[2].signed_w0,
               s11 = corners[3].signed_w0;
  if (w_max <= 1e-12 * std::max(std::fabs(s_min), std::fabs(s_max))) {
    // In focus: the edge's own line, w0 = 0, splits the pixel's area.
    p.side = PixelH::kInFocus;
    p.slope_a = 0.5 * ((s10 - s00) + (s11 - s01));
    p.slope_b = 0.5 * ((s01 - s00) + (s11 - s10));
    p.centre = 0.25 * (s00 + s10 + s01 + s11);
    const double twist = s00 - s10 - s01 + s11;
    const double grad = std::max(std::fabs(p.slope_a), std::fabs(p.slope_b));
    p.error_h = grad > 0 ? std::fabs(twist) / (4 * grad) : (twist == 0 ? 0 : INFINITY);
    return p;
  }
  double h[4], w_change = 0, dx = 0, dy = 0;
  for (int i = 0; i < 4; ++i) {
    h[i] = corners[i].signed_w0 / w_mean;
    // The exact h is signed_w0 / w_norm: using the mean |w| moves it by h (w/mean - 1),
    // which matters only where |h| < 1 (elsewhere the coverage is 0 or 1 either way).
    w_change = std::max(w_change, std::fabs(corners[i].w_norm / w_mean - 1));
    dx += corners[i].dir_x;
    dy += corners[i].dir_y;
  }
  p.side = PixelH::kLinear;
  p.slope_a = 0.5 * ((h[1] - h[0]) + (h[3] - h[2]));
  p.slope_b = 0.5 * ((h[2] - h[0]) + (h[3] - h[1]));
  p.centre = 0.25 * (h[0] + h[1] + h[2] + h[3]);
  p.error_h = 0.25 * std::fabs(h[0] - h[1] - h[2] + h[3]) + w_change;
  const double norm = std::hypot(dx, dy);
  if (norm > 0) {
    p.dir_x = dx / norm;
    p.dir_y = dy / norm;
    for (int i = 0; i < 4; ++i)
      p.dir_error =
          std::max(p.dir_error, std::hypot(corners[i].dir_x - p.dir_x, corners[i].dir_y - p.dir_y));
  }
  return p;
}

double pixel_edge_coverage(const EdgeTerms corners[4], double tolerance) {
  const PixelH p = pixel_h(corners);
  switch (p.side) {
    case PixelH::kNegative:
      return 0;
    case PixelH::kPositive:
      return 1;
    case PixelH::kInFocus:
      if (p.error_h > tolerance) return NAN;
      return pixel_positive_share(p.centre, p.slope_a, p.slope_b);
    case PixelH::kLinear:
      break;
  }
  // Coverage changes by at most 2/pi per unit of h, over the share of the pixel where
  // |h| < 1 (at most 2 / the larger slope).
  const double near_edge =
      std::min(1.0, 2 / std::max({std::fabs(p.slope_a), std::fabs(p.slope_b), 1e-300}));
  const double error = 2 * kInvPi * p.error_h * near_edge;
  if (!(error <= tolerance)) return NAN;
  return pixel_mean_coverage(p.centre, p.slope_a, p.slope_b);
}

}  // namespace camlab::mock
