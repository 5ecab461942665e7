// Pillbox edge model and its slanted-edge fit. The header is the reference; this file
// says how the closed forms stay accurate and why the fit is set up as it is.
#include "analysis/edge/edge_spread.h"
#include "analysis/edge/edge_fit_core.h"
#include "analysis/edge/levenberg_marquardt.h"
#include "base/format.h"

#include <algorithm>
#include <array>
#include <bitset>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace camlab::analysis {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kInf = std::numeric_limits<double>::infinity();

// ---- The profile and its antiderivatives in unit-radius coordinates u = x / R ----------
//
// For |u| < 1, with s = sqrt(1 - u^2) and w = asin u:
//   esf(u) = 1/2 + (u s + w) / pi
//   G(u)   = int esf du = u/2 + (u w + s - s^3/3) / pi                 (G(-1) = 0, G(1) = 1)
//   K(u)   = int G du   = u^2/4 + ((u^2/2 + 1/8) w + 5/8 u s - u s^3/12) / pi + 1/16
//                                                                    (K(-1) = 0, K(1) = 5/8)
// Outside: esf = 0, G = 0, K = 0 for u <= -1; esf = 1, G = u, K = u^2/2 + 1/8 for u >= 1
// (1/8 = half the variance 1/4 of the unit disk's line spread function).
struct UnitTerms {
  double esf, g, k;
};

UnitTerms unit_terms_inside(double u) {
  const double s = std::sqrt(std::max(0.0, 1.0 - u * u));
  const double w = std::asin(u);
  const double s3 = s * s * s;
  return {
      0.5 + (u * s + w) / kPi, 0.5 * u + (u * w + s - s3 / 3.0) / kPi,
      0.25 * u * u + ((0.5 * u * u + 0.125) * w + 0.625 * u * s - u * s3 / 12.0) / kPi + 0.0625};
}

// At a trapezoid corner x (pixels) for a blur of radius R > 0, the functions whose second
// differences give the pixel value and its derivatives. Each is written so that it is
// compactly supported or constant outside [-R, R]: second differences of constants cancel
// exactly, so rounding stays at eps * (value size) instead of eps * x^2.
//   e2    = H - H_step: H'' = esf, H_step = max(x, 0)^2 / 2             (-> P)
//   f     = F = H': first antiderivative of the esf                    (-> P, box form)
//   fblur = F - max(x, 0)                                              (-> dP/dd)
//   dh_dr = dH/dR = R (2 K - u G) inside, 0 below, R/4 above           (-> dP/dR)
//   df_dr = dF/dR = G - u esf inside, 0 outside                        (-> dP/dR, box form)
struct CornerTerms {
  double esf, f, fblur, e2, dh_dr, df_dr;
};

CornerTerms corner_terms(double x, double radius) {
  const double u = x / radius;
  if (u <= -1.0) return {0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
  if (u >= 1.0) return {1.0, x, 0.0, 0.125 * radius * radius, 0.25 * radius, 0.0};
  const UnitTerms t = unit_terms_inside(u);
  const double up = std::max(u, 0.0);
  return {t.esf,
          radius * t.g,
          radius * (t.g - up),
          radius * radius * (t.k - 0.5 * up * up),
          radius * (2.0 * t.k - u * t.g),
          t.g - u * t.esf};
}

// The unit square projected onto the normal: a trapezoid of base a + b and top a - b,
// a = max(|nx|, |ny|) >= 1/sqrt 2, b = min(|nx|, |ny|) in [0, 1/sqrt 2].
struct Trapezoid {
  double a, b;
};

Trapezoid trapezoid_for(double nx, double ny) {
  const double ax = std::fabs(nx), ay = std::fabs(ny);
  return {std::max(ax, ay), std::min(ax, ay)};
}

// A pixel's value and its derivatives by the signed distance d, the radius R and the
// trapezoid's a and b (through which the pixel's footprint changes with the angle).
struct PixelModel {
  double p, dp_dd, dp_dr, dp_da, dp_db;
};

// An unblurred step seen through the trapezoid: its CDF at d, its density, and their
// derivatives by a and b. Exact; on the ramps (r = distance into a ramp, r <= b) every
// term stays bounded as b -> 0.
PixelModel step_pixel(double d, const Trapezoid& tz) {
  const double c1 = 0.5 * (tz.a - tz.b), c2 = 0.5 * (tz.a + tz.b), ad = std::fabs(d);
  if (ad >= c2) return {d > 0 ? 1.0 : 0.0, 0.0, 0.0, 0.0, 0.0};
  if (ad <= c1 || tz.b == 0.0) return {0.5 + d / tz.a, 1.0 / tz.a, 0.0, -d / (tz.a * tz.a), 0.0};
  const double r = c2 - ad, two_ab = 2.0 * tz.a * tz.b, ramp = r * r / two_ab;
  const double sign = d < 0 ? 1.0 : -1.0;  // P = r^2 / 2ab below the edge, 1 - that above
  return {d < 0 ? ramp : 1.0 - ramp, 2.0 * r / two_ab, 0.0, sign * (r / two_ab - ramp / tz.a),
          sign * (r / two_ab - ramp / tz.b)};
}

// The trapezoid-averaged ESF. Two closed forms:
//  - full: P = step + Q / (a b), Q = e2(x1) - e2(x2) - e2(x3) + e2(x4) at the corners
//    x = d +- (a +- b)/2. Rounding: ~eps R^2 / (a b).
//  - box (b -> 0, near 0 degrees): P = (F(d + a/2) - F(d - a/2)) / a, which drops the
//    trapezoid's ramps; its error is b^2 max|esf'| / (24 a) <= b^2 / (12 pi R a).
// Switching at b = 6e-6 R balances the two (both below ~1e-10 for R up to 1000 px).
// The derivatives differentiate the same closed forms (corners move by +-1/2 with a, b).
PixelModel pixel_model(double d, double radius, const Trapezoid& tz) {
  if (!(radius > 0.0)) return step_pixel(d, tz);
  const double c1 = 0.5 * (tz.a - tz.b), c2 = 0.5 * (tz.a + tz.b);
  // Beyond the blur and the pixel: exactly flat (the common case, so checked first).
  if (d - c2 >= radius) return {1.0, 0.0, 0.0, 0.0, 0.0};
  if (d + c2 <= -radius) return {0.0, 0.0, 0.0, 0.0, 0.0};
  PixelModel m{};
  if (tz.b < 6e-6 * radius) {
    const CornerTerms hi = corner_terms(d + 0.5 * tz.a, radius);
    const CornerTerms lo = corner_terms(d - 0.5 * tz.a, radius);
    m.p = (hi.f - lo.f) / tz.a;
    m.dp_dd = (hi.esf - lo.esf) / tz.a;
    m.dp_dr = (hi.df_dr - lo.df_dr) / tz.a;
    m.dp_da = (0.5 * (hi.esf + lo.esf) - m.p) / tz.a;  // dP/db = O(b): 0
  } else {
    const CornerTerms t1 = corner_terms(d + c2, radius), t2 = corner_terms(d + c1, radius);
    const CornerTerms t3 = corner_terms(d - c1, radius), t4 = corner_terms(d - c2, radius);
    const double ab = tz.a * tz.b;
    const double q = (t1.e2 - t2.e2) - (t3.e2 - t4.e2);
    const double dq_da = 0.5 * ((t1.fblur - t2.fblur) + (t3.fblur - t4.fblur));
    const double dq_db = 0.5 * ((t1.fblur + t2.fblur) - (t3.fblur + t4.fblur));
    m = step_pixel(d, tz);
    m.p += q / ab;
    m.dp_dd += ((t1.fblur - t2.fblur) - (t3.fblur - t4.fblur)) / ab;
    m.dp_dr = ((t1.dh_dr - t2.dh_dr) - (t3.dh_dr - t4.dh_dr)) / ab;
    m.dp_da += (dq_da - q / tz.a) / ab;
    m.dp_db += (dq_db - q / tz.b) / ab;
  }
  m.p = std::clamp(m.p, 0.0, 1.0);
  return m;
}

// Sanitised radius from a diameter: NaN or negative -> 0 (the header's contract).
double radius_from(double diameter_px) { return diameter_px > 0.0 ? 0.5 * diameter_px : 0.0; }

// ---- The fit ---------------------------------------------------------------------------

// 10-90% rise of the pillbox ESF in units of D: esf(u90) = 0.9 -> rise = 2 u90 R = u90 D.
constexpr double kU90 = 0.68704882613254048;
// 10-90% rise of a pixel's own trapezoid (0.8 px for the box at 0 degrees, 0.78 px for
// the triangle at 45): removed in quadrature from the measured rise for the start value.
constexpr double kPixelRise_px = 0.8;
constexpr int kMinSamples = 32;
constexpr int kMaxIterations = 200;

// The parameter vector; D = |q| keeps D >= 0 without a bound (and the model's slope by
// D vanishes at D = 0, so q passes through 0 smoothly).
enum { kOffset, kAngle, kDark, kLight, kQ, kParams };
using Params = std::array<double, kParams>;

struct Sample {
  double dx_px, dy_px;  // pixel centre minus the guess point
  double value;
};

// The normal, its trapezoid, and how the trapezoid's a and b change with the angle
// (a = |nx| or |ny|, whichever is larger; nx = -sin theta, ny = cos theta).
struct Normal {
  double nx, ny;
  Trapezoid tz;
  double da_dangle, db_dangle;
};

Normal normal_for(double angle_rad) {
  const double nx = -std::sin(angle_rad), ny = std::cos(angle_rad);
  const auto sign = [](double v) { return v > 0 ? 1.0 : (v < 0 ? -1.0 : 0.0); };
  const double dax = sign(nx) * -ny, day = sign(ny) * nx;  // d|nx|/dtheta, d|ny|/dtheta
  const bool x_major = std::fabs(nx) >= std::fabs(ny);
  return {nx, ny, trapezoid_for(nx, ny), x_major ? dax : day, x_major ? day : dax};
}

// A fixed angle has a zero column.
using Normals = edge_fit::NormalEquations<kParams>;

// Evaluates the model and its Jacobian at every sample; with `by_diameter` the last
// column is d/dD rather than d/dq (for the covariance of D).
Normals evaluate(const std::vector<Sample>& samples, const Params& p, bool fit_angle,
                 bool by_diameter) {
  const Normal nm = normal_for(p[kAngle]);
  const double radius = 0.5 * std::fabs(p[kQ]);
  const double contrast = p[kLight] - p[kDark];
  const double dr_dq = 0.5 * ((by_diameter || p[kQ] >= 0) ? 1.0 : -1.0);  // R = |q| / 2
  Normals out;
  Params row{};
  for (const Sample& s : samples) {
    const double d = s.dx_px * nm.nx + s.dy_px * nm.ny - p[kOffset];
    const PixelModel m = pixel_model(d, radius, nm.tz);
    const double r = s.value - (p[kDark] + contrast * m.p);
    row[kOffset] = -contrast * m.dp_dd;
    if (fit_angle) {
      // d moves with the angle through the lever arm (-along); the pixel's footprint
      // changes shape too (not its variance: a^2 + b^2 = 1), a small term.
      const double along = s.dx_px * nm.ny - s.dy_px * nm.nx;
      const double shape = m.dp_da * nm.da_dangle + m.dp_db * nm.db_dangle;
      row[kAngle] = contrast * (-along * m.dp_dd + shape);
    }
    row[kDark] = 1.0 - m.p;
    row[kLight] = m.p;
    row[kQ] = contrast * m.dp_dr * dr_dq;
    out.add(row, r);
  }
  out.symmetrise();
  return out;
}

// The damped step (edge_fit::solve_damped) with the angle pinned when it is not fitted;
// with `inverse`, (J^T J)^-1 instead (edge_fit::invert_normals). False if singular.
bool solve_normals(const Normals& ne, double lambda, bool fit_angle, Params* step,
                   cv::Mat* inverse = nullptr) {
  std::bitset<kParams> pinned;
  pinned[kAngle] = !fit_angle;
  if (inverse) return edge_fit::invert_normals(ne, pinned, inverse);
  return edge_fit::solve_damped(ne, lambda, pinned, step);
}

// Start values from the profile across the guessed edge (`across`: signed distance of
// each sample from the guessed line). `ok` false: a side of the window is empty.
struct Start {
  bool ok = false;
  double dark = 0, light = 0, noise = 0, offset_px = 0, diameter_px = 0;
};

Start start_values(const std::vector<double>& across, const std::vector<Sample>& samples,
                   double half_width_px) {
  Start st;
  // Levels and noise from the outer quarters, which hold no blur when the window is
  // large enough (and only bias the start when it is not).
  const double outer = half_width_px - std::max(1.0, 0.25 * half_width_px);
  double sum[2] = {0, 0}, sum2[2] = {0, 0};
  int count[2] = {0, 0};
  for (size_t i = 0; i < across.size(); ++i) {
    if (std::fabs(across[i]) < outer) continue;
    const int side = across[i] > 0 ? 1 : 0;
    sum[side] += samples[i].value;
    sum2[side] += samples[i].value * samples[i].value;
    ++count[side];
  }
  if (count[0] < 2 || count[1] < 2) return st;
  st.ok = true;
  st.dark = sum[0] / count[0];
  st.light = sum[1] / count[1];
  const double ss =
      std::max(0.0, sum2[0] - sum[0] * st.dark) + std::max(0.0, sum2[1] - sum[1] * st.light);
  st.noise = std::sqrt(ss / (count[0] + count[1] - 2));
  const double contrast = st.light - st.dark;
  if (!(std::fabs(contrast) > 0.0)) return st;

  // Profile normalised to 0..1 in 0.5 px bins. Edge position from the area under it
  // (robust to noise): for a blur inside the window, mean = (half_width - e) / (2 hw).
  const double bin_px = 0.5;
  const int bins = static_cast<int>(std::ceil(2.0 * half_width_px / bin_px)) + 1;
  std::vector<double> bin_sum(bins, 0.0);
  std::vector<int> bin_count(bins, 0);
  double mean = 0;
  for (size_t i = 0; i < across.size(); ++i) {
    const double v = (samples[i].value - st.dark) / contrast;
    const int b = std::clamp(static_cast<int>((across[i] + half_width_px) / bin_px), 0, bins - 1);
    bin_sum[b] += v;
    ++bin_count[b];
    mean += v / static_cast<double>(across.size());
  }
  st.offset_px = std::clamp(half_width_px * (1.0 - 2.0 * mean), -half_width_px, half_width_px);
  std::vector<double> pos, prof;
  for (int b = 0; b < bins; ++b) {
    if (bin_count[b] == 0) continue;
    pos.push_back(-half_width_px + (b + 0.5) * bin_px);
    prof.push_back(bin_sum[b] / bin_count[b]);
  }
  // 10-90% rise: the first crossings of 0.1 and 0.9 walking out from the edge. A crossing
  // lies between neighbours that straddle the level, so interpolation never divides by 0.
  size_t centre = 0;
  while (centre + 1 < pos.size() && pos[centre] < st.offset_px) ++centre;
  auto interpolate = [&](size_t j, size_t k, double level) {
    return pos[j] + (level - prof[j]) / (prof[k] - prof[j]) * (pos[k] - pos[j]);
  };
  double x90 = pos.back(), x10 = pos.front();
  if (prof[centre] >= 0.9) x90 = pos[centre];
  for (size_t i = centre; x90 == pos.back() && i + 1 < pos.size(); ++i)
    if (prof[i + 1] >= 0.9) x90 = interpolate(i, i + 1, 0.9);
  if (prof[centre] <= 0.1) x10 = pos[centre];
  for (size_t i = centre; x10 == pos.front() && i > 0; --i)
    if (prof[i - 1] <= 0.1) x10 = interpolate(i - 1, i, 0.1);
  const double rise = x90 - x10;
  const double blur_rise =
      std::sqrt(std::max(rise * rise - kPixelRise_px * kPixelRise_px, 0.09 * rise * rise));
  // Never start at 0: there the model's slope by D vanishes and D could not move.
  st.diameter_px = std::clamp(blur_rise / kU90, 0.5, 2.0 * half_width_px);
  return st;
}

// Levenberg-Marquardt with Marquardt's diagonal scaling (levels in DN and lengths in px
// differ by orders of magnitude). Stops when a step changes no parameter by more than
// ~1e-9 (px, or of the contrast for levels), when the cost stops falling (relative
// 1e-13), or when D or the offset runs off beyond the window (`runaway`).
struct Solution {
  Params p;
  int iterations = 0;
  bool converged = false, runaway = false;
};

Solution levenberg_marquardt(const std::vector<Sample>& samples, Params p, bool fit_angle,
                             double half_length_px, double half_width_px) {
  Normals ne = evaluate(samples, p, fit_angle, false);
  const LmOutcome lm = levenberg_marquardt_loop(
      &p, &ne, kMaxIterations,
      [&](const Normals& n, double lambda, Params* step) {
        return solve_normals(n, lambda, fit_angle, step);
      },
      [&](const Params& trial) { return evaluate(samples, trial, fit_angle, false); },
      [&](const Params& step, const Params& q) {
        const double level_tol = 1e-9 * std::fabs(q[kLight] - q[kDark]);
        return std::fabs(step[kOffset]) < 1e-9 && std::fabs(step[kQ]) < 1e-9 &&
               std::fabs(step[kAngle]) * half_length_px < 1e-9 &&
               std::fabs(step[kDark]) <= level_tol && std::fabs(step[kLight]) <= level_tol;
      },
      [&](const Params& q) {
        return std::fabs(q[kQ]) > 4.0 * half_width_px ||
               std::fabs(q[kOffset]) > 2.0 * half_width_px;
      });
  Solution sol;
  sol.iterations = lm.iterations;
  sol.converged = lm.converged;
  sol.runaway = lm.runaway;
  sol.p = p;
  return sol;
}

}  // namespace

double pillbox_esf(double x_px, double diameter_px) {
  if (std::isnan(x_px) || diameter_px == kInf) return 0.5;
  const double radius = radius_from(diameter_px);
  if (radius == 0.0) return x_px > 0 ? 1.0 : (x_px < 0 ? 0.0 : 0.5);
  const double u = x_px / radius;
  if (u <= -1.0) return 0.0;
  if (u >= 1.0) return 1.0;
  return std::clamp(unit_terms_inside(u).esf, 0.0, 1.0);
}

double pillbox_esf_pixel(double distance_px, double diameter_px, double normal_x, double normal_y) {
  if (std::isnan(distance_px) || diameter_px == kInf) return 0.5;
  double norm = std::hypot(normal_x, normal_y);
  if (!(norm > 0.0) || !std::isfinite(norm)) {
    normal_x = 0.0;
    normal_y = 1.0;
    norm = 1.0;
  }
  const Trapezoid tz = trapezoid_for(normal_x / norm, normal_y / norm);
  return pixel_model(distance_px, radius_from(diameter_px), tz).p;
}

PixelEsf pillbox_esf_pixel_terms(double distance_px, double diameter_px, double angle_rad) {
  if (std::isnan(distance_px) || !std::isfinite(diameter_px) || !std::isfinite(angle_rad))
    return {0.5, 0.0, 0.0, 0.0};
  const Normal nm = normal_for(angle_rad);
  const PixelModel m = pixel_model(distance_px, radius_from(diameter_px), nm.tz);
  return {m.p, m.dp_dd, 0.5 * m.dp_dr, m.dp_da * nm.da_dangle + m.dp_db * nm.db_dangle};
}

Result<EdgeFit> fit_pillbox_edge(const cv::Mat& image, const EdgeLine& guess,
                                 const EdgeFitOptions& options) {
  constexpr ErrorCode invalid = kErrInvalidArgument;
  if (Status checked = edge_fit::check_fittable_image(image); !checked) return checked.error();
  if (!std::isfinite(guess.x_px) || !std::isfinite(guess.y_px) || !std::isfinite(guess.angle_rad)) {
    return make_error(invalid, "the guessed edge line must be finite");
  }
  const double hl = options.half_length_px, hw = options.half_width_px;
  if (!(hl >= 1.0 && hw >= 1.0) || !std::isfinite(hl) || !std::isfinite(hw)) {
    return make_error(invalid,
                      "half_length_px and half_width_px must be finite and >= 1 "
                      "(got " +
                          format_significant(hl, 3) + ", " + format_significant(hw, 3) + ")");
  }

  // The window: |along| <= hl, |across| <= hw around the guess point.
  auto window = edge_fit::sample_window(
      image, {guess.x_px, guess.y_px, guess.angle_rad, hl, -hw, hw}, "the fit window");
  if (!window) return window.error();
  std::vector<Sample> samples;
  std::vector<double> across;  // signed distance from the guessed line, px
  samples.reserve(window->size());
  across.reserve(window->size());
  for (const edge_fit::WindowPixel& pixel : *window) {
    samples.push_back({pixel.col - guess.x_px, pixel.row - guess.y_px, pixel.value});
    across.push_back(pixel.across_px);
  }
  if (static_cast<int>(samples.size()) < kMinSamples) {
    return make_error(kErrTooFewPixels,
                      "the fit window holds " + std::to_string(samples.size()) +
                          " usable pixels; at least " + std::to_string(kMinSamples) +
                          " are needed (enlarge half_length_px or half_width_px)");
  }
  const Start st = start_values(across, samples, hw);
  if (!st.ok) {
    return make_error(kErrTooFewPixels,
                      "a side of the fit window has fewer than 2 pixels in its outer "
                      "quarter; enlarge half_length_px");
  }
  const double level_scale = std::max({1.0, std::fabs(st.dark), std::fabs(st.light)});
  if (!(std::fabs(st.light - st.dark) > std::max(st.noise, 1e-12 * level_scale))) {
    return make_error(kErrNoContrast, "the two sides of the window differ by " +
                                          format_significant(st.light - st.dark, 3) +
                                          ", not more than the noise " +
                                          format_significant(st.noise, 3) + "; no edge to fit");
  }

  // Orient the normal towards the light side, so that light > dark throughout the fit.
  Params start{st.offset_px, guess.angle_rad, st.dark, st.light, st.diameter_px};
  if (st.light < st.dark) {
    start = {-st.offset_px, guess.angle_rad + kPi, st.light, st.dark, st.diameter_px};
  }
  const Solution sol = levenberg_marquardt(samples, start, options.fit_angle, hl, hw);
  Params p = sol.p;
  if (p[kLight] < p[kDark]) {  // the model is symmetric: P(-d) = 1 - P(d)
    p = {-p[kOffset], p[kAngle] + kPi, p[kLight], p[kDark], p[kQ]};
  }
  p[kAngle] = std::remainder(p[kAngle], 2.0 * kPi);
  const double diameter = std::fabs(p[kQ]);

  // The blur plus 2 px of flat level on each side must lie inside the window, wherever
  // the fitted edge ended up in it.
  const double shift_px =
      std::fabs(p[kOffset]) + hl * std::fabs(std::sin(p[kAngle] - guess.angle_rad));
  const double needed_px = 0.5 * diameter + 2.0 + shift_px;
  if (hw < needed_px || sol.runaway) {
    const bool shifted = shift_px > 0.01;
    return make_error(
        kErrWindowTooSmall,
        "half_width_px " + format_significant(hw, 3) + " is too small for a blur diameter of " +
            format_significant(diameter, 3) + " px" +
            (shifted ? " with the edge " + format_significant(shift_px, 3) + " px off centre"
                     : "") +
            ": need >= D/2 + 2" + (shifted ? " + shift" : "") + " = " +
            format_significant(needed_px, 3) + " px");
  }
  if (!sol.converged) {
    return make_error(kErrNotConverged, "the edge fit did not converge in " +
                                            std::to_string(kMaxIterations) +
                                            " iterations (D = " + format_significant(diameter, 3) +
                                            " px); check the guess");
  }

  const int n_samples = static_cast<int>(samples.size());
  const int n_params = options.fit_angle ? kParams : kParams - 1;
  const Normals fin = evaluate(samples, p, options.fit_angle, true);
  const double rms = std::sqrt(fin.cost / std::max(1, n_samples - n_params));
  const double contrast = p[kLight] - p[kDark];
  if (!(contrast > rms)) {
    return make_error(kErrNoContrast,
                      "the fitted edge contrast " + format_significant(contrast, 3) +
                          " is below the residual noise " + format_significant(rms, 3));
  }
  // sigma^2 = rms^2 (J^T J)^-1 at the solution, by D itself (not q). Singular (no
  // information on D): +infinity.
  double sigma = kInf;
  cv::Mat cov;
  if (solve_normals(fin, 0.0, options.fit_angle, nullptr, &cov)) {
    const double var = rms * rms * cov.at<double>(kQ, kQ);
    if (var >= 0.0 && std::isfinite(var)) sigma = std::sqrt(var);
  }

  EdgeFit fit;
  fit.diameter_px = diameter;
  fit.diameter_sigma_px = sigma;
  fit.offset_px = p[kOffset];
  fit.angle_rad = p[kAngle];
  const Normal fitted = normal_for(p[kAngle]);
  fit.line = {guess.x_px + p[kOffset] * fitted.nx, guess.y_px + p[kOffset] * fitted.ny, p[kAngle]};
  fit.dark_level = p[kDark];
  fit.light_level = p[kLight];
  fit.rms_residual = rms;
  fit.contrast_to_noise = rms > 0.0 ? contrast / rms : kInf;
  fit.samples = n_samples;
  fit.iterations = sol.iterations;
  return fit;
}

}  // namespace camlab::analysis
