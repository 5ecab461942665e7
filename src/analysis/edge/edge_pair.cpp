// Joint fit of two overlapping edges (edge_pair.h): Levenberg-Marquardt over eight
// parameters with the analytic Jacobian of the pixel-integrated pillbox model.
#include "analysis/edge/edge_pair.h"
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
constexpr int kMaxIterations = 200;

enum { kOff1, kAng1, kOff2, kAng2, kL0, kL1, kL2, kQ, kParams };
using Params = std::array<double, kParams>;

struct Sample {
  double x, y, value;  // pixel centre, value
};

struct Line {
  double px, py;  // guess point
};

using Normals = edge_fit::NormalEquations<kParams>;

// Model, residuals and normal equations at p. `by_diameter`: the last column is d/dD
// (for the covariance) instead of d/dq.
Normals evaluate(const std::vector<Sample>& samples, const Line& l1, const Line& l2,
                 const Params& p, bool by_diameter) {
  const double n1x = -std::sin(p[kAng1]), n1y = std::cos(p[kAng1]);
  const double n2x = -std::sin(p[kAng2]), n2y = std::cos(p[kAng2]);
  const double d = std::fabs(p[kQ]);
  const double dd_dq = (by_diameter || p[kQ] >= 0) ? 1.0 : -1.0;
  const double step1 = p[kL1] - p[kL0], step2 = p[kL2] - p[kL1];
  Normals out;
  Params row{};
  for (const Sample& s : samples) {
    const double rx1 = s.x - l1.px, ry1 = s.y - l1.py, rx2 = s.x - l2.px, ry2 = s.y - l2.py;
    const double d1 = rx1 * n1x + ry1 * n1y - p[kOff1], d2 = rx2 * n2x + ry2 * n2y - p[kOff2];
    const PixelEsf e1 = pillbox_esf_pixel_terms(d1, d, p[kAng1]);
    const PixelEsf e2 = pillbox_esf_pixel_terms(d2, d, p[kAng2]);
    const double model = p[kL0] + step1 * e1.value + step2 * e2.value;
    const double r = s.value - model;
    // Along each line (its direction (cos a, sin a)): the lever arm of the angle.
    const double along1 = rx1 * n1y - ry1 * n1x, along2 = rx2 * n2y - ry2 * n2x;
    row[kOff1] = -step1 * e1.d_distance;
    row[kAng1] = step1 * (-along1 * e1.d_distance + e1.d_angle_footprint);
    row[kOff2] = -step2 * e2.d_distance;
    row[kAng2] = step2 * (-along2 * e2.d_distance + e2.d_angle_footprint);
    row[kL0] = 1.0 - e1.value;
    row[kL1] = e1.value - e2.value;
    row[kL2] = e2.value;
    row[kQ] = (step1 * e1.d_diameter + step2 * e2.d_diameter) * dd_dq;
    out.add(row, r);
  }
  out.symmetrise();
  return out;
}

// The damped step (edge_fit::solve_damped); with `pin_diameter` D keeps its value (the
// profile of the cost in D).
bool solve_step(const Normals& ne, double lambda, bool pin_diameter, Params* step) {
  std::bitset<kParams> pinned;
  pinned[kQ] = pin_diameter;
  return edge_fit::solve_damped(ne, lambda, pinned, step);
}

struct Solution {
  Params p;
  double cost = kInf;
  int iterations = 0;
  bool converged = false;
};

// Levenberg-Marquardt with Marquardt's scaling (as fit_pillbox_edge). Not converged when
// it runs off beyond the window (`reach`: its width).
Solution levenberg_marquardt(const std::vector<Sample>& samples, const Line& l1, const Line& l2,
                             Params p, double half_length, double reach,
                             bool pin_diameter = false) {
  Normals ne = evaluate(samples, l1, l2, p, false);
  const LmOutcome lm = levenberg_marquardt_loop(
      &p, &ne, kMaxIterations,
      [&](const Normals& n, double lambda, Params* step) {
        return solve_step(n, lambda, pin_diameter, step);
      },
      [&](const Params& trial) { return evaluate(samples, l1, l2, trial, false); },
      [&](const Params& step, const Params&) {
        return std::fabs(step[kOff1]) < 1e-9 && std::fabs(step[kOff2]) < 1e-9 &&
               std::fabs(step[kQ]) < 1e-9 &&
               (std::fabs(step[kAng1]) + std::fabs(step[kAng2])) * half_length < 1e-9;
      },
      [&](const Params& q) {
        return std::fabs(q[kQ]) > 2 * reach || std::fabs(q[kOff1]) > reach ||
               std::fabs(q[kOff2]) > reach;
      });
  Solution sol;
  sol.iterations = lm.iterations;
  sol.converged = lm.converged && !lm.runaway;
  sol.p = p;
  sol.cost = ne.cost;
  return sol;
}

double mean_of(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return v.empty() ? 0.0 : s / v.size();
}

}  // namespace

Result<EdgePairFit> fit_pillbox_edge_pair(const cv::Mat& image, const EdgeLine& guess_a,
                                          const EdgeLine& guess_b, const EdgePairFitOptions& o) {
  constexpr ErrorCode invalid = kErrInvalidArgument;
  if (Status checked = edge_fit::check_fittable_image(image); !checked) return checked.error();
  for (double v :
       {guess_a.x_px, guess_a.y_px, guess_a.angle_rad, guess_b.x_px, guess_b.y_px,
        guess_b.angle_rad, o.half_length_px, o.across_min_px, o.across_max_px, o.diameter_guess_px})
    if (!std::isfinite(v))
      return make_error(invalid, "the guessed lines and the window must be finite");
  if (!(o.half_length_px >= 4) || !(o.across_max_px - o.across_min_px >= 4) ||
      !(o.diameter_guess_px > 0))
    return make_error(
        invalid, "the window must be at least 8 px long and 4 px wide, the diameter guess > 0");
  // Both directions the same way round; b's side of a decides which line comes first.
  const double ta_x = std::cos(guess_a.angle_rad), ta_y = std::sin(guess_a.angle_rad);
  double angle_b = guess_b.angle_rad;
  if (std::cos(angle_b) * ta_x + std::sin(angle_b) * ta_y < 0) angle_b += kPi;
  const double tilt = std::fabs(std::remainder(angle_b - guess_a.angle_rad, 2 * kPi));
  if (tilt > 15.0 * kPi / 180.0)
    return make_error(invalid, "the two edges are " + format_significant(tilt * 180 / kPi, 3) +
                                   " deg from parallel (at most 15)");
  const double na_x = -ta_y, na_y = ta_x;
  const double c_b = (guess_b.x_px - guess_a.x_px) * na_x + (guess_b.y_px - guess_a.y_px) * na_y;
  if (std::fabs(c_b) < 0.25) return make_error(invalid, "the two guessed lines coincide");
  const bool b_first = c_b < 0;

  // The window's pixels: |along| <= hl, across in [min, max], about line a's point.
  const double hl = o.half_length_px;
  auto window = edge_fit::sample_window(
      image, {guess_a.x_px, guess_a.y_px, guess_a.angle_rad, hl, o.across_min_px, o.across_max_px},
      "the pair's fit window");
  if (!window) return window.error();
  std::vector<Sample> samples;
  std::vector<double> across;  // from line a's guess
  samples.reserve(window->size());
  across.reserve(window->size());
  for (const edge_fit::WindowPixel& pixel : *window) {
    samples.push_back(
        {static_cast<double>(pixel.col), static_cast<double>(pixel.row), pixel.value});
    across.push_back(pixel.across_px);
  }
  if (samples.size() < 64)
    return make_error(kErrTooFewPixels, "the pair's fit window holds " +
                                            std::to_string(samples.size()) + " pixels; 64 needed");

  // Internal order: line 1 on the -n side, line 2 on the +n side.
  const EdgeLine& g1 = b_first ? EdgeLine{guess_b.x_px, guess_b.y_px, angle_b} : guess_a;
  const EdgeLine& g2 = b_first ? guess_a : EdgeLine{guess_b.x_px, guess_b.y_px, angle_b};
  const Line l1{g1.x_px, g1.y_px}, l2{g2.x_px, g2.y_px};
  const double pos1 = b_first ? c_b : 0.0, pos2 = b_first ? 0.0 : c_b;  // across of each line
  const double sep = pos2 - pos1;
  // Several starts for D: from a small one, a blur far larger than the start settles in
  // a local minimum where the lines move apart to mimic it. The guess, then a ladder of
  // factors of 2 from a quarter of the guess (at least 1 px) up to what the window can
  // hold; the least cost wins.
  std::vector<double> starts = {o.diameter_guess_px};
  const double widest = std::max(1.0, o.across_max_px - o.across_min_px - sep - 4.0);
  for (double d = std::exp2(std::floor(std::log2(std::max(1.0, 0.25 * o.diameter_guess_px))));
       d <= widest; d *= 2.0)
    if (std::fabs(std::log2(d / o.diameter_guess_px)) > 0.5) starts.push_back(d);
  Params p{};
  double best_cost = kInf;
  std::vector<std::pair<double, double>> minima;  // (cost, D) of every converged start
  int iterations = 0;
  std::string start_error;
  for (double d0 : starts) {
    // Start levels: beyond each line's blur, and between them from the middle value.
    std::vector<double> before, after, middle;
    for (size_t i = 0; i < samples.size(); ++i) {
      if (across[i] < pos1 - 0.5 * d0 - 1) before.push_back(samples[i].value);
      if (across[i] > pos2 + 0.5 * d0 + 1) after.push_back(samples[i].value);
      if (std::fabs(across[i] - 0.5 * (pos1 + pos2)) <= 0.5) middle.push_back(samples[i].value);
    }
    if (before.size() < 4 || after.size() < 4 || middle.empty()) {
      start_error =
          "the pair's window leaves no flat level beyond one of the edges for a blur of about " +
          format_significant(d0, 3) + " px";
      continue;
    }
    const double lev0 = mean_of(before), lev2 = mean_of(after), vmid = mean_of(middle);
    const double pa = pillbox_esf(0.5 * sep, d0), pb = pillbox_esf(-0.5 * sep, d0);
    const double lev1 = (vmid - lev0 * (1 - pa) - lev2 * pb) / std::max(pa - pb, 0.05);
    const Solution sol = levenberg_marquardt(
        samples, l1, l2, {0.0, g1.angle_rad, 0.0, g2.angle_rad, lev0, lev1, lev2, d0}, hl,
        o.across_max_px - o.across_min_px);
    iterations += sol.iterations;
    if (sol.converged) minima.emplace_back(sol.cost, std::fabs(sol.p[kQ]));
    if (sol.converged && sol.cost < best_cost) {
      best_cost = sol.cost;
      p = sol.p;
    }
  }
  if (!(best_cost < kInf)) {
    if (!start_error.empty() && iterations == 0) return make_error(kErrWindowTooSmall, start_error);
    return make_error(kErrNotConverged,
                      "the joint fit of the two edges did not converge from any of " +
                          std::to_string(starts.size()) + " starts");
  }
  const double diameter = std::fabs(p[kQ]);

  // The fitted lines' points and their positions across the window.
  const double n1x = -std::sin(p[kAng1]), n1y = std::cos(p[kAng1]);
  const double n2x = -std::sin(p[kAng2]), n2y = std::cos(p[kAng2]);
  const EdgeLine f1{l1.px + p[kOff1] * n1x, l1.py + p[kOff1] * n1y, p[kAng1]};
  const EdgeLine f2{l2.px + p[kOff2] * n2x, l2.py + p[kOff2] * n2y, p[kAng2]};
  // Signed distance of a window corner from a fitted line; the window must hold D/2 + 2
  // beyond each line along its whole length, and line 2 must stay on line 1's +n side.
  auto dist = [&](const EdgeLine& f, double nx, double ny, double al, double ac) {
    const double x = guess_a.x_px + al * ta_x + ac * na_x, y = guess_a.y_px + al * ta_y + ac * na_y;
    return (x - f.x_px) * nx + (y - f.y_px) * ny;
  };
  double gap = kInf, margin1 = kInf, margin2 = kInf;
  const double lo = o.across_min_px, hi = o.across_max_px;
  for (double al : {-hl, 0.0, hl}) {
    // Along the window, where line 2 crosses the across axis minus where line 1 does.
    const double c1 = -dist(f1, n1x, n1y, al, 0.0) / (n1x * na_x + n1y * na_y);
    const double c2 = -dist(f2, n2x, n2y, al, 0.0) / (n2x * na_x + n2y * na_y);
    gap = std::min(gap, c2 - c1);
    margin1 = std::min(margin1, -dist(f1, n1x, n1y, al, lo));
    margin2 = std::min(margin2, dist(f2, n2x, n2y, al, hi));
  }
  if (!(gap > 0.5))
    return make_error("not_converged",
                      "the joint fit put the two edges " + format_significant(gap, 3) +
                          " px apart or through each other: no pair of edges in the data");
  if (margin1 < 0.5 * diameter + 2 || margin2 < 0.5 * diameter + 2)
    return make_error(kErrWindowTooSmall, "the pair's window leaves " +
                                              format_significant(std::min(margin1, margin2), 3) +
                                              " px beyond an edge; a blur of " +
                                              format_significant(diameter, 3) + " px needs " +
                                              format_significant(0.5 * diameter + 2, 3));

  const int n = static_cast<int>(samples.size());
  const Normals fin = evaluate(samples, l1, l2, p, true);
  const double rms = std::sqrt(fin.cost / std::max(1, n - kParams));
  const double smaller_step = std::min(std::fabs(p[kL1] - p[kL0]), std::fabs(p[kL2] - p[kL1]));
  if (!(smaller_step > 3 * rms))
    return make_error(kErrNoContrast,
                      "one of the two edges has a step of " + format_significant(smaller_step, 3) +
                          ", not above 3x the residual noise " + format_significant(rms, 3));
  EdgePairFit out;
  out.diameter_px = diameter;
  out.diameter_sigma_px = kInf;
  out.diameter_vif = kInf;
  cv::Mat cov;
  if (edge_fit::invert_normals(fin, {}, &cov)) {
    const double var = rms * rms * cov.at<double>(kQ, kQ);
    if (var >= 0 && std::isfinite(var)) out.diameter_sigma_px = std::sqrt(var);
    out.diameter_vif = cov.at<double>(kQ, kQ) * fin.jtj[kQ * kParams + kQ];
  }
  // How far the cost's profile in D is from the quadratic the sigma assumes: at D' the
  // cost (the rest refitted) rises by dchi2 = (cost' - cost) / rms^2, which a quadratic
  // cost makes ((D' - D) / sigma)^2. Probes at +-5 sigma and +-20%, each started with
  // the lines moved apart or together so that the profile keeps its second moment
  // (sep^2 / 12 + D^2 / 16): when the bar's width and the blur trade off, another minimum
  // lies there. Another start's minimum that fits as well (dchi2 < 4) more than 3 sigma
  // away counts as a ratio of 0.
  const double sigma_d = std::isfinite(out.diameter_sigma_px) ? out.diameter_sigma_px : 0.0;
  out.diameter_profile_ratio = 1.0;
  auto dchi2 = [&](double cost) { return std::max(0.0, cost - best_cost) / (rms * rms); };
  if (sigma_d > 0) {
    for (const auto& [cost, dia] : minima)
      if (std::fabs(dia - diameter) >= 3 * sigma_d && dchi2(cost) < 4.0)
        out.diameter_profile_ratio = 0.0;
    for (double probe :
         {diameter - 5 * sigma_d, diameter + 5 * sigma_d, 0.8 * diameter, 1.2 * diameter}) {
      const double k = (probe - diameter) / sigma_d;
      const double sep2 = gap * gap + 0.75 * (diameter * diameter - probe * probe);
      if (!(probe > 0.05) || std::fabs(k) < 3 || !(sep2 > 0.25)) continue;
      const double widen = std::sqrt(sep2) - gap;
      Params start = p;
      start[kQ] = probe;
      start[kOff1] -= 0.5 * widen;
      start[kOff2] += 0.5 * widen;
      const Solution held =
          levenberg_marquardt(samples, l1, l2, start, hl, o.across_max_px - o.across_min_px, true);
      if (held.converged)
        out.diameter_profile_ratio =
            std::min(out.diameter_profile_ratio, dchi2(held.cost) / (k * k));
    }
  }
  out.line_a = b_first ? f2 : f1;
  out.line_b = b_first ? f1 : f2;
  out.separation_px = gap;
  out.level_0 = p[kL0];
  out.level_1 = p[kL1];
  out.level_2 = p[kL2];
  out.rms_residual = rms;
  out.contrast_to_noise = rms > 0 ? smaller_step / rms : kInf;
  out.samples = n;
  out.iterations = iterations;
  return out;
}

}  // namespace camlab::analysis
