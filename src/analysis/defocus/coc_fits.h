// The thin lens's two laws of blur, fitted to measured disk diameters
// (docs/physics.md, "Circle of confusion"):
//  - against the aperture: C = A |z_s - z_i| / z_i with A = f / N, so C = k / N and
//    C x N = k is constant across an aperture series;
//  - against the focus: C is proportional to |z_s - z_i|, and z_s is linear in the focus
//    motor position, so C traces a V: C = s |p - p0| (s = slope per step).
// Inputs are per-frame diameters (px) with their 1-sigma uncertainties. Weighted least
// squares; parameter uncertainties are scaled by sqrt(chi^2 / dof) when that exceeds 1
// (the reported sigmas then cover effects the per-edge sigma misses, e.g. the renderer's
// aperture sampling).
//
// Reentrant: pure functions.
#pragma once

#include <span>
#include <string>
#include <vector>

#include "base/result.h"

namespace camlab::analysis {

struct BlurSample {
  double x = 0;  // f-number (aperture fit) or focus position in steps (V-curve)
  double diameter_px = 0;
  double sigma_px = 0;  // 1 sigma; <= 0 or non-finite: the sample is skipped
};

// C = k / N. `cn_deviation[i]` = C_i N_i / k - 1 (the frame's consistency; the
// "C x N constant" check), `normalized_residual[i]` = (C_i - k / N_i) / sigma_i, both for
// the samples used (`used[i]`). Samples with D below `min_diameter_px` (default 1 px,
// where pixels and noise dominate) are left out.
struct ApertureFit {
  double k_px = 0;  // C x N in px
  double k_sigma_px = 0;
  double chi2_per_dof = 0;
  double max_abs_cn_deviation = 0;
  int used_count = 0;
  std::vector<bool> used;
  std::vector<double> cn_deviation;
  std::vector<double> normalized_residual;
};
// Errors: "too_few_samples" (fewer than 2 usable samples), "invalid_argument".
Result<ApertureFit> fit_coc_vs_aperture(std::span<const BlurSample> samples,
                                        double min_diameter_px = 1.0);

// C = s |p - p0|, fitted over every split of the sorted positions into a falling and a
// rising arm (for a split the model is linear in s and s p0); the split with the least
// chi^2 whose p0 lies between its arms wins. Samples below `min_diameter_px` are left
// out: near focus the baseline blur and diffraction round the V. `p0_at_end` is set when
// the minimum is not bracketed by samples on both arms (a one-armed sweep: p0 is then an
// extrapolation and flagged as such).
struct VCurveFit {
  double best_position = 0;  // p0, steps (sub-step)
  double best_position_sigma = 0;
  double slope_px_per_step = 0;  // s
  double slope_sigma = 0;
  double chi2_per_dof = 0;
  int used_count = 0;
  int left_count = 0, right_count = 0;
  bool p0_at_end = false;
  std::vector<bool> used;
};
// Errors: "too_few_samples" (fewer than 3 usable samples), "invalid_argument".
Result<VCurveFit> fit_v_curve(std::span<const BlurSample> samples, double min_diameter_px = 1.0);

}  // namespace camlab::analysis
