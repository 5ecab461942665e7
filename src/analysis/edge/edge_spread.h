// Blur diameter from a slanted edge: the exact edge spread function (ESF) of a uniform
// disk (pillbox) blur, its average over a square pixel, and a Levenberg-Marquardt fit of
// that model to the pixels around an edge (docs/physics.md, "Measuring blur from an edge").
//
// Why an exact model: a defocused thin lens spreads a point into a uniform disk of
// diameter D. A Gaussian fit converted to a diameter is biased by 3-32% depending on D;
// this model, integrated over the pixel in closed form, has no model bias, so the fitted
// D is limited by noise alone (0.01-0.04 px at a contrast-to-noise ratio of 50, growing
// with D; see EdgeFitOptions).
//
// Conventions: lengths in pixels (`_px`), angles in radians (`_rad`). Pixel coordinates
// have pixel centres at integers, x to the right, y down; a pixel is the unit square
// around its centre with a 100% fill factor. An edge line has a direction angle theta
// (from +x towards +y); its unit normal is n = (-sin theta, cos theta), and the signed
// distance of a point p from the line through p0 is (p - p0) . n. The light side of an
// edge is the side n points to.
//
// No function returns NaN. The profile functions sanitise their inputs (documented per
// function); the fit returns an Error whose code is stable (kErr* below) and whose message
// says what was wrong and what is needed.
//
// Reentrant: no state. Depends on OpenCV core (cv::Mat) and the standard library.
#pragma once

#include <string_view>

#include <opencv2/core/mat.hpp>

#include "base/result.h"

namespace camlab::analysis {

// The error codes of fit_pillbox_edge() (base/error_code.h).
inline constexpr ErrorCode kErrInvalidArgument = ErrorCode::kInvalidArgument;  // option, type
inline constexpr ErrorCode kErrWindowOutsideImage = ErrorCode::kWindowOutsideImage;
inline constexpr ErrorCode kErrTooFewPixels = ErrorCode::kTooFewSamples;
inline constexpr ErrorCode kErrNoContrast = ErrorCode::kNoContrast;  // |light - dark| < noise
inline constexpr ErrorCode kErrWindowTooSmall = ErrorCode::kWindowTooSmall;  // blur not inside
inline constexpr ErrorCode kErrNotConverged = ErrorCode::kNotConverged;

// ---- The pillbox edge profile ---------------------------------------------------------

// The edge spread function of a uniform disk of diameter `diameter_px`: the fraction of
// the disk centred at signed distance `x_px` from a straight edge that lies on the light
// side (x > 0). With R = D/2 and u = x/R:
//   ESF = 1/2 + (u sqrt(1 - u^2) + asin u) / pi   for |u| < 1,  0 below, 1 above.
// D = 0 is the unit step (1/2 exactly at x = 0). Its derivative, the line spread function,
// is (2 / (pi R)) sqrt(1 - u^2); its variance is R^2/4 = D^2/16.
// Sanitised inputs: a negative or NaN diameter is taken as 0, an infinite one gives 1/2;
// a NaN x gives 1/2. Result in [0, 1].
double pillbox_esf(double x_px, double diameter_px);

// The pillbox ESF averaged over a unit-square pixel whose centre lies at signed distance
// `distance_px` from the edge, for an edge of normal (normal_x, normal_y). The square
// projects onto the normal as a trapezoid of base |nx| + |ny| and top ||nx| - |ny||
// (a box at 0 degrees, a triangle at 45), so this is the ESF convolved with that
// trapezoid, evaluated in closed form from the ESF's first and second antiderivatives
// (no sampling). Accurate to about 1e-11 absolute for every D >= 0 and every angle,
// including D -> 0 and the exact 0 and 45 degree cases: near 0 degrees the form switches
// to its box limit before cancellation sets in. (Measured: 3e-12 against fine quadrature
// at 0 and 45 degrees; exact to 1e-15 against clipped-square areas for D = 0.)
// The normal need not be unit length (it is normalised); a zero or non-finite normal is
// taken as (0, 1). Other inputs are sanitised as in pillbox_esf(). Result in [0, 1].
double pillbox_esf_pixel(double distance_px, double diameter_px, double normal_x, double normal_y);

// The pixel-integrated ESF of pillbox_esf_pixel() for an edge of direction `angle_rad`
// (normal (-sin a, cos a)), with its derivatives, for fits that build on the model (the
// joint fit of two edges, edge_pair.h): by the signed distance, by the diameter, and by
// the angle through the pixel's footprint alone (the trapezoid's shape; the lever arm of
// a pixel along the line is the caller's). Inputs sanitised as in pillbox_esf_pixel().
struct PixelEsf {
  double value = 0, d_distance = 0, d_diameter = 0, d_angle_footprint = 0;
};
PixelEsf pillbox_esf_pixel_terms(double distance_px, double diameter_px, double angle_rad);

// ---- Fitting an edge ------------------------------------------------------------------

// A straight edge: a point on it and the direction of the line (see Conventions above
// for the normal and which side is light).
struct EdgeLine {
  double x_px = 0;
  double y_px = 0;
  double angle_rad = 0;
};

// Which pixels the fit uses: those whose centres lie within `half_length_px` of the guess
// point along the guessed line and within `half_width_px` of the line across it. The
// window must hold the whole blur plus 2 px of flat level on each side:
// half_width_px >= D/2 + 2 (+ any misplacement of the guess); D/2 + 8 is a good choice.
// The spread of D falls as 1/sqrt(length): at a contrast-to-noise ratio of 50 and
// half_length_px = 60 it is about 0.015-0.02 px for D <= 5, 0.03 at D = 10, 0.043 at 20
// and 0.056 at 30; an edge 10 diameters long brings D = 30 to 0.035 px.
struct EdgeFitOptions {
  double half_length_px = 60;
  double half_width_px = 16;
  bool fit_angle = true;  // false: keep the guessed angle (e.g. a known target geometry)
};

// The fitted edge. Levels are in the image's units (DN for integer images). The fitted
// edge line passes through `line` (the point nearest the guess point); `angle_rad` equals
// line.angle_rad and may differ from the guess by about pi, because the fit orients the
// normal towards the light side (light_level > dark_level).
// `offset_px` is the shift of the fitted edge from the guess point along the fitted
// normal. `diameter_sigma_px` is the 1-sigma uncertainty from the Jacobian,
// sigma^2 = rms^2 (J^T J)^-1 with rms^2 = sum(residual^2) / (samples - parameters); it
// matches the scatter over noise draws to about 10-25% for D >= 1. It is +infinity where
// the data carry no information on D: D fitted as exactly 0, or an edge aligned with the
// pixel grid whose blur is so small that one row of pixels holds the whole transition (D
// and the offset then trade off). Near D = 0 the model changes as D^2, so the linearised
// sigma means little: at contrast-to-noise 50 a sharp edge fits anywhere in 0..0.15 px.
// Slant edges by a few degrees: at exactly 0 degrees every row samples the same sub-pixel
// phase, and the spread at D = 1 is twice that at 5 degrees.
// `contrast_to_noise` = |light - dark| / rms_residual, +infinity for an exact fit.
struct EdgeFit {
  double diameter_px = 0;
  double diameter_sigma_px = 0;
  double offset_px = 0;
  double angle_rad = 0;
  EdgeLine line;
  double dark_level = 0;
  double light_level = 0;
  double rms_residual = 0;
  double contrast_to_noise = 0;
  int samples = 0;     // pixels used
  int iterations = 0;  // Levenberg-Marquardt iterations (accepted or rejected steps)
};

// Fits the pixel-integrated pillbox edge model
//   value(p) = dark + (light - dark) * pillbox_esf_pixel((p - p0) . n(theta) - offset, D, n)
// to the pixels of `image` (single channel CV_8U, CV_16U, CV_32F or CV_64F; non-finite
// float pixels are skipped) inside the window around `guess` (p0 = the guess point), by
// Levenberg-Marquardt over offset, theta (if options.fit_angle), dark, light and D, with
// D = |q| so that it stays >= 0, and an analytic Jacobian (including the change of the
// pixel's trapezoid with theta). The start: levels from the outer quarters of the
// window, offset from the area under the profile, D from its 10-90% rise distance.
// Errors: kErrInvalidArgument (empty or unsupported image, non-finite guess, window
// half-sizes < 1 px or non-finite), kErrWindowOutsideImage (a window corner lies outside
// the pixel centres of the image), kErrTooFewPixels (< 32 usable pixels, or < 2 in the
// outer quarter of a side), kErrNoContrast (|light - dark| below the noise, before or
// after the fit, or a constant image), kErrWindowTooSmall (half_width_px < D/2 + 2 + the fitted
// edge's displacement within the window; the message gives the half-width needed),
// kErrNotConverged.
//
// Cost (one core, -O2): 0.6 ms per edge at D = 1, 1.2 ms at D = 5 and 6 ms at D = 30 for a
// 120 px long window (about 7 iterations); it grows with the pixels inside the blur.
Result<EdgeFit> fit_pillbox_edge(const cv::Mat& image, const EdgeLine& guess,
                                 const EdgeFitOptions& options);

}  // namespace camlab::analysis
