// Exposure analysis on linear raw frames (docs/physics.md, "Exposure"):
//  - photon transfer per EMVA 1288 from pairs of frames at the same setting: the temporal
//    variance of the signal (half the variance of the pair's difference, which removes
//    fixed pattern) against its mean above dark is a line of slope K, the system gain in
//    DN per electron: sigma_y^2 = sigma_y,dark^2 + K (mu_y - mu_dark);
//  - linearity of the mean signal in T x gain;
//  - an HDR radiance merge of a bracket with inverse-variance weights.
// Signals are in DN above the black level (`_dn`), variances in DN^2, exposure times in
// microseconds, gains linear (1 = unity).
//
// Reentrant: pure functions.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "base/result.h"

namespace camlab::analysis {

// One frame pair's statistics over a region: mean of both frames above dark, and the
// temporal variance var(A - B) / 2.
struct PairStats {
  double exposure_us = 0, gain = 1;
  double mean_dn = 0;
  double variance_dn2 = 0;
  int64_t pixels = 0;
  bool used = false;  // in the K fit (0-70% of saturation)
  // Part of the pair's pixels at the clip level (a bright area of the scene clipped while
  // the rest did not): its variance has partly collapsed and its mean is not the sensor's
  // response, so the pair is left out of every fit, whatever its mean.
  bool saturated = false;
  double clipped_fraction = 0;  // of its pixels at or above the clip level
};

// Mean and temporal variance of two frames (single channel, same size and type) inside
// `roi` (empty: the whole frame), after subtracting `black_level_dn`. Errors:
// "invalid_argument" (mismatched, empty, multi-channel, roi outside).
Result<PairStats> pair_stats(const cv::Mat& a, const cv::Mat& b, double black_level_dn,
                             const cv::Rect& roi = cv::Rect());

// EMVA 1288 results. The line is fitted by weighted least squares (weight = 1 / the
// variance of a variance estimate, 2 var^2 / (n - 1)) over the pairs not saturated (no part
// of them clipped) whose mean lies below 70% of the saturation mean, when the data reached
// saturation (all of them otherwise); the saturation point is the pair of largest variance
// (where clipping starts to eat the noise). The dark variance sigma_y,dark^2 comes from
// the lowest pair when its mean is below 5% of saturation (its variance minus the shot
// part K mu: exact for a dark pair, and far better determined than the line's intercept),
// else from the intercept.
// dark_noise_e = sqrt(max(0, sigma_y,dark^2 - 1/12)) / K (the 1/12 DN^2 is quantisation);
// saturation_capacity_e = mu_sat / K; snr_max = mu_e,sat / sqrt(sigma_d^2 + 1/(12 K^2) +
// mu_e,sat); dynamic_range = mu_e,sat / sigma_d (sigma_d in e-, floored at 1/(K sqrt 12)
// e- so that a noiseless sensor's range stays finite).
struct PhotonTransfer {
  double system_gain_dn_per_e = 0;  // K
  double system_gain_sigma = 0;
  double dark_variance_dn2 = 0;
  double dark_mean_dn = 0;  // 0: signals are already above dark
  double dark_noise_e = 0;
  double saturation_mean_dn = 0;  // mu_sat above dark
  double saturation_capacity_e = 0;
  double snr_max = 0;
  double dynamic_range = 0;
  double expected_gain_dn_per_e = 0;  // filled by callers that know the spec (0 = unknown)
  // Whether the sweep reached saturation (a pair saturated, or a brighter pair's variance
  // collapsed). When not, saturation_mean_dn is the brightest pair's and the capacity,
  // SNR max and dynamic range derived from it are lower bounds, not the sensor's.
  bool saturation_reached = false;
  int used_count = 0;
  std::vector<PairStats> points;
};
// The saturation point: the pair of largest variance (EMVA 1288) places it up to a factor
// 2 below the clip on a coarse sweep such as doubling exposures, and the saturation
// capacity with it. So the first brighter pair whose variance has collapsed (under half
// the peak's: mostly clipped) gives it instead, its mean being where the sensor clips; and
// `clip_mean_dn` (the signal above black at which frames were seen to clip, from their
// histograms), when given and higher, gives it.
// Errors: "too_few_samples" (fewer than 3 pairs below 70% of saturation), "no_signal".
Result<PhotonTransfer> fit_photon_transfer(std::vector<PairStats> points,
                                           std::optional<double> clip_mean_dn = std::nullopt);

// Linearity: the mean signal against H = T x gain, a line through the origin fitted to
// the relative residuals over the points between 5% and 95% of `saturation_dn`;
// error_pct = 100 (mean - slope H) / (slope H) for every point.
struct LinearityPoint {
  double exposure_gain_us = 0;
  double mean_dn = 0;
  double error_pct = 0;
  bool used = false;
  bool saturated = false;  // part of its frame clipped (see PairStats): never used
};
struct Linearity {
  double slope_dn_per_us = 0;
  double max_abs_error_pct = 0;
  int used_count = 0;
  std::vector<LinearityPoint> points;
};
// Errors: "too_few_samples" (fewer than 2 usable points).
// `saturation_known` false (a sweep that never reached saturation: saturation_dn is only its
// brightest mean, a lower bound) drops the 95% cap.
Result<Linearity> fit_linearity(std::vector<LinearityPoint> points, double saturation_dn,
                                bool saturation_known = true);

// One frame of a bracket: DN above black (CV_32F), its exposure and gain, the level at
// which it clips (DN above black), and its noise model var = gain K0 signal + read_var.
struct HdrFrame {
  cv::Mat signal_dn;
  double exposure_us = 0, gain = 1;
  double clip_dn = 0;
};
struct HdrNoise {
  double k_dn_per_e = 1;         // K at unity gain
  double read_variance_dn2 = 1;  // at unity gain; scaled by gain^2
};
// The merge: radiance in DN per microsecond at unity gain, x_i = s_i / (T_i g_i), combined
// with weights 1 / var(x_i), var(x_i) = (g K max(s_i, 0) + g^2 read) / (T_i g_i)^2, over
// the frames where the pixel is below 97% of clip_dn. A pixel clipped in every frame gets
// the lower bound clip_dn / (T g) of its least exposed frame and a set bit in `clipped`
// (255); `radiance` is never NaN. `sigma` is the 1-sigma of the estimate (for clipped
// pixels: 0).
struct HdrResult {
  cv::Mat radiance;     // CV_32F
  cv::Mat sigma;        // CV_32F
  cv::Mat clipped;      // CV_8U, 255 = clipped in every frame
  cv::Mat frames_used;  // CV_8U, frames contributing per pixel
  int64_t clipped_everywhere = 0;
};
// Errors: "invalid_argument" (no frames, sizes differ, T, gain or clip <= 0, bad noise).
Result<HdrResult> merge_hdr(std::span<const HdrFrame> frames, const HdrNoise& noise);

}  // namespace camlab::analysis
