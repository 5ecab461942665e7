// Per-edge blur-disk diameter from a slanted edge in a frame: chooses the fit window from
// the edge's geometry and the blur it finds, rejects edges whose window cannot hold the
// blur (target too small, neighbour too close, image border), removes the lens's in-focus
// baseline blur, and flags diameters below the diffraction floor (docs/physics.md,
// "Measuring blur"). The exact pillbox fit itself is fit_pillbox_edge() (edge_spread.h).
//
// Baseline blur: a real lens (and the virtual camera's lens.baseline_blur_sigma_px) adds
// a Gaussian of sigma_b px to the thin lens's disk. Fitting a pure disk to disk (x) Gaussian
// gives an apparent diameter D_app(D) > D (D_app(0) is about 3.2 sigma_b). This file inverts
// that map exactly for the frame's geometry: D_app(D) is computed by fitting the same
// model to a noise-free synthetic edge rendered as the virtual camera renders it (pixel-
// integrated disk, then a sampled Gaussian), and solved for D by bracketed secant steps.
// A measured D_app at or below D_app(0) means "in focus to within the baseline".
//
// Conventions: pixel centres at integers (edge_spread.h); lengths in px.
// Reentrant: no state.
#pragma once

#include <cmath>
#include <span>
#include <string>
#include <string_view>

#include <opencv2/core/mat.hpp>

#include "analysis/edge/edge_spread.h"
#include "base/result.h"

namespace camlab::analysis {

// Contrast-to-noise per pixel (edge step over the noise sigma) under which an edge's
// measurement is flagged low_signal, and the relative bias its sigma then includes.
inline constexpr double kLowSignalCnr = 10.0;
inline constexpr double kLowSignalRelativeBias = 0.01;

// Status of one edge measurement. Only kEdgeOk is a measurement of D; the others say why
// not, and keep whatever was fitted for reference.
inline constexpr std::string_view kEdgeOk = "ok";
inline constexpr std::string_view kEdgeBelowDiffraction = "below_diffraction_floor";
inline constexpr std::string_view kEdgeAtBaseline = "at_baseline";  // in focus within baseline
inline constexpr std::string_view kEdgeWindowTooSmall = "window_too_small";
inline constexpr std::string_view kEdgeNeighbourOverlap = "neighbour_overlap";  // even jointly
inline constexpr std::string_view kEdgeClipped = "clipped";
inline constexpr std::string_view kEdgeFitFailed = "fit_failed";

// An edge segment in the image: from `start` to `end` (px). `max_half_width_px` bounds
// the window across the edge (how far the two flat sides extend, e.g. half a slanted-edge
// target's size); <= 0: only the image and neighbours bound it.
struct EdgeSegment {
  std::string name;
  double start_x_px = 0, start_y_px = 0;
  double end_x_px = 0, end_y_px = 0;
  double max_half_width_px = 0;
};

struct EdgeMeasureOptions {
  double baseline_sigma_px = 0;     // Gaussian in-focus blur of the lens; 0 = none
  double airy_diameter_px = 0;      // diffraction floor 2.44 lambda N / pitch; 0 = ignore
  double saturation_level = 0;      // image value at which pixels clip; <= 0 = none
  double confidence_sigmas = 1.96;  // half-width of the confidence interval (95%)
};

// One edge's result. `diameter_px` is the thin-lens disk diameter (baseline removed),
// with the interval [ci_low_px, ci_high_px] = D +- confidence_sigmas x sigma mapped
// through the baseline inversion (never below 0). `apparent_diameter_px` is the raw fit.
// For kEdgeAtBaseline, diameter_px = 0 and ci_high_px bounds it. For
// kEdgeBelowDiffraction the numbers are what the pixels show, not a measurement of the
// geometric blur. For the rejections the window and the message say what was needed.
struct EdgeMeasurement {
  std::string name;
  std::string status;
  std::string message;  // empty for kEdgeOk
  double diameter_px = 0;
  double diameter_sigma_px = 0;
  double ci_low_px = 0, ci_high_px = 0;
  double apparent_diameter_px = 0;
  double rms_residual = 0;
  double contrast_to_noise = 0;
  // Contrast-to-noise per pixel under kLowSignalCnr: the fit is still a measurement, but
  // its noise is large and the interval was widened to cover it (docs/analysis.md).
  bool low_signal = false;
  double half_length_px = 0, half_width_px = 0;  // the window used (or last tried)
  EdgeFit fit;  // valid unless status is a rejection before any fit succeeded
  // Set when a neighbouring edge's blur overlapped the window and both were fitted
  // together with one diameter (edge_pair.h): the neighbour's name and their distance.
  std::string joint_with;
  double joint_separation_px = 0;
  bool measured() const { return status == kEdgeOk; }
  // The interval's upper end says nothing: infinite, or past the window across the edge
  // (a blur wider than the window cannot show in it). Reports say "unconstrained" there,
  // never a number such as 8810527.724 px.
  bool upper_unconstrained() const {
    return !std::isfinite(ci_high_px) || (half_width_px > 0 && ci_high_px > 2 * half_width_px);
  }
};

// Measures one edge of `image` (single channel, any type fit_pillbox_edge() takes).
// `neighbours` are other edges in the image (their distance bounds the window).
// Returns an Error only for invalid input (empty image, degenerate segment shorter than
// 8 px, non-finite numbers); every other outcome is an EdgeMeasurement with a status.
Result<EdgeMeasurement> measure_edge(const cv::Mat& image, const EdgeSegment& edge,
                                     std::span<const EdgeSegment> neighbours,
                                     const EdgeMeasureOptions& options);

// The apparent (pure-disk fit) diameter of a disk of `diameter_px` blurred by a Gaussian
// of `sigma_px`, for an edge at `angle_rad`: the fit of a noise-free synthetic edge.
// sigma_px = 0 returns diameter_px. Errors from the fit are passed on.
Result<double> apparent_diameter_px(double diameter_px, double sigma_px, double angle_rad);

// The inverse: the disk diameter D >= 0 whose apparent diameter is `apparent_px`, to
// 1e-4 px. `at_baseline` is set when apparent_px <= D_app(0) (then D = 0). `slope` is
// dD_app/dD at the solution (for mapping uncertainties), 1 when sigma_px = 0.
struct BaselineInversion {
  double diameter_px = 0;
  double slope = 1;
  double apparent_at_zero_px = 0;
  bool at_baseline = false;
};
Result<BaselineInversion> remove_baseline_blur(double apparent_px, double sigma_px,
                                               double angle_rad);

// Renders the noise-free edge model the virtual camera produces: value = dark + (light -
// dark) x pixel-integrated disk ESF at the signed distance of each pixel from the line,
// then a sampled Gaussian of sigma_px (cv::GaussianBlur, reflected border) when > 0.
// CV_32F, rows x cols. For tests, benchmarks and the baseline inversion.
cv::Mat render_edge_model(int rows, int cols, const EdgeLine& line, double diameter_px,
                          double sigma_px, double dark, double light);

}  // namespace camlab::analysis
