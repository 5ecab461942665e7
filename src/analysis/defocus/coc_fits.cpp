// Weighted least-squares fits of C = k / N and of the V-curve C = s |p - p0|.
#include "analysis/defocus/coc_fits.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

namespace camlab::analysis {
namespace {

bool usable(const BlurSample& s, double min_diameter_px) {
  return std::isfinite(s.x) && std::isfinite(s.diameter_px) && std::isfinite(s.sigma_px) &&
         s.sigma_px > 0 && s.diameter_px >= min_diameter_px;
}

}  // namespace

Result<ApertureFit> fit_coc_vs_aperture(std::span<const BlurSample> samples,
                                        double min_diameter_px) {
  ApertureFit fit;
  fit.used.assign(samples.size(), false);
  fit.cn_deviation.assign(samples.size(), 0.0);
  fit.normalized_residual.assign(samples.size(), 0.0);
  // Minimise sum w (C - k u)^2 with u = 1/N, w = 1/sigma^2: k = sum(w C u) / sum(w u^2).
  double swcu = 0, swuu = 0;
  for (size_t i = 0; i < samples.size(); ++i) {
    const BlurSample& s = samples[i];
    if (!usable(s, min_diameter_px)) continue;
    if (!(s.x > 0)) return make_error("invalid_argument", "f-numbers must be > 0");
    const double u = 1.0 / s.x, w = 1.0 / (s.sigma_px * s.sigma_px);
    swcu += w * s.diameter_px * u;
    swuu += w * u * u;
    fit.used[i] = true;
    ++fit.used_count;
  }
  if (fit.used_count < 2)
    return make_error("too_few_samples",
                      "C = k/N needs at least 2 frames with a measured blur >= " +
                          std::to_string(min_diameter_px) + " px; got " +
                          std::to_string(fit.used_count));
  fit.k_px = swcu / swuu;
  double chi2 = 0;
  for (size_t i = 0; i < samples.size(); ++i) {
    if (!fit.used[i]) continue;
    const BlurSample& s = samples[i];
    const double r = (s.diameter_px - fit.k_px / s.x) / s.sigma_px;
    fit.normalized_residual[i] = r;
    fit.cn_deviation[i] = s.diameter_px * s.x / fit.k_px - 1.0;
    fit.max_abs_cn_deviation = std::max(fit.max_abs_cn_deviation, std::fabs(fit.cn_deviation[i]));
    chi2 += r * r;
  }
  fit.chi2_per_dof = chi2 / (fit.used_count - 1);
  fit.k_sigma_px = std::sqrt(std::max(1.0, fit.chi2_per_dof) / swuu);
  return fit;
}

Result<VCurveFit> fit_v_curve(std::span<const BlurSample> samples, double min_diameter_px) {
  std::vector<size_t> order;
  for (size_t i = 0; i < samples.size(); ++i)
    if (usable(samples[i], min_diameter_px)) order.push_back(i);
  if (order.size() < 3)
    return make_error("too_few_samples",
                      "a V-curve needs at least 3 frames with a measured blur >= " +
                          std::to_string(min_diameter_px) + " px; got " +
                          std::to_string(order.size()));
  std::sort(order.begin(), order.end(),
            [&](size_t a, size_t b) { return samples[a].x < samples[b].x; });
  const size_t n = order.size();

  struct Candidate {
    double chi2 = std::numeric_limits<double>::infinity();
    double s = 0, b = 0, var_s = 0, var_b = 0, cov_sb = 0;
    size_t split = 0;
  } best;
  // Split j: order[0..j) on the falling arm (C = b - s p), order[j..n) on the rising arm
  // (C = s p - b), with b = s p0. j = 0 or n is a one-armed fit (p0 outside the sweep).
  for (size_t j = 0; j <= n; ++j) {
    double a11 = 0, a12 = 0, a22 = 0, r1 = 0, r2 = 0;
    for (size_t k = 0; k < n; ++k) {
      const BlurSample& s = samples[order[k]];
      const double sign = k < j ? -1.0 : 1.0, w = 1.0 / (s.sigma_px * s.sigma_px);
      const double g1 = sign * s.x, g2 = -sign;  // C = s g1 + b g2
      a11 += w * g1 * g1;
      a12 += w * g1 * g2;
      a22 += w * g2 * g2;
      r1 += w * g1 * s.diameter_px;
      r2 += w * g2 * s.diameter_px;
    }
    const double det = a11 * a22 - a12 * a12;
    if (!(std::fabs(det) > 1e-12 * (a11 * a22 + 1e-300))) continue;
    const double s_hat = (a22 * r1 - a12 * r2) / det, b_hat = (a11 * r2 - a12 * r1) / det;
    if (!(s_hat > 0)) continue;
    const double p0 = b_hat / s_hat;
    // The minimum must lie between the arms (with a one-armed fit, beyond the sweep).
    const double lo = j > 0 ? samples[order[j - 1]].x : -std::numeric_limits<double>::infinity();
    const double hi = j < n ? samples[order[j]].x : std::numeric_limits<double>::infinity();
    if (p0 < lo || p0 > hi) continue;
    double chi2 = 0;
    for (size_t k = 0; k < n; ++k) {
      const BlurSample& s = samples[order[k]];
      const double r = (s.diameter_px - s_hat * std::fabs(s.x - p0)) / s.sigma_px;
      chi2 += r * r;
    }
    if (chi2 < best.chi2) {
      best = {chi2, s_hat, b_hat, a22 / det, a11 / det, -a12 / det, j};
    }
  }
  if (!std::isfinite(best.chi2))
    return make_error("no_v_shape",
                      "no V-shaped fit C = s |p - p0| with s > 0 matches the "
                      "measured diameters (blur does not grow away from a focus)");
  VCurveFit fit;
  fit.used.assign(samples.size(), false);
  for (size_t i : order) fit.used[i] = true;
  fit.used_count = static_cast<int>(n);
  fit.left_count = static_cast<int>(best.split);
  fit.right_count = static_cast<int>(n - best.split);
  fit.p0_at_end = best.split == 0 || best.split == n;
  fit.chi2_per_dof = n > 2 ? best.chi2 / static_cast<double>(n - 2) : 0.0;
  const double scale = std::max(1.0, fit.chi2_per_dof);
  fit.slope_px_per_step = best.s;
  fit.best_position = best.b / best.s;
  fit.slope_sigma = std::sqrt(scale * best.var_s);
  // p0 = b / s: delta method.
  const double p0 = fit.best_position;
  const double var_p0 =
      (best.var_b - 2.0 * p0 * best.cov_sb + p0 * p0 * best.var_s) / (best.s * best.s);
  fit.best_position_sigma = std::sqrt(scale * std::max(0.0, var_p0));
  return fit;
}

}  // namespace camlab::analysis
