// Joint fit of two nearly parallel edges whose blurs overlap (a bar, a narrow gap, two
// steps), with one shared blur diameter: where a single-edge window cannot hold one blur
// plus flat level without taking in the neighbour's blur, the two are fitted together.
//
// Model (edge_spread.h conventions: pixel centres at integers, lengths in px, an edge's
// normal n = (-sin a, cos a)). With d_a(p), d_b(p) a pixel's signed distances from the two
// lines, both normals oriented the same way and line b on the +n side of line a:
//   value(p) = L0 + (L1 - L0) P(d_a(p), D) + (L2 - L1) P(d_b(p), D)
// P the pixel-integrated pillbox ESF. By linearity of the blur this is exact for two
// parallel steps (L0 before a, L1 between, L2 after b): a dark bar is L1 < L0 = L2, two
// rising steps L0 < L1 < L2. Free: both offsets and angles, the three levels and D (8).
//
// Conditioning. When the edges are much closer than the blur, the bar's width and its
// level trade off (only their product shows) and D can trade with them; the fit then
// says so instead of returning a number: `diameter_vif` is the variance inflation of D,
// (J^T J)^-1_DD (J^T J)_DD, the factor by which the other parameters' correlation with D
// inflates its variance (1: none), and `diameter_profile_ratio` says whether the cost
// is as curved in D as that sigma assumes. Callers reject fits where it is not
// (defocus.cpp: a ratio below 0.1, or a VIF above 50).
//
// Reentrant: no state.
#pragma once

#include <opencv2/core/mat.hpp>

#include "analysis/edge/edge_spread.h"
#include "base/result.h"

namespace camlab::analysis {

// The window: pixels within `half_length_px` of line a's guess point along line a, and
// between `across_min_px` and `across_max_px` from line a's guess line along its normal
// (so it can extend further on the side where line b lies).
struct EdgePairFitOptions {
  double half_length_px = 40;
  double across_min_px = -16, across_max_px = 16;
  double diameter_guess_px = 4;  // start value of D (> 0); starts from a quarter of it up
};

struct EdgePairFit {
  double diameter_px = 0;
  double diameter_sigma_px = 0;  // 1 sigma from rms^2 (J^T J)^-1; +inf when singular
  double diameter_vif = 0;       // variance inflation of D (header)
  // How the cost rises in D against the quadratic that diameter_sigma_px assumes: the
  // least, over probes at +-5 sigma and +-20%, of dchi2 / ((D' - D) / sigma)^2 (0 when
  // another start ends in a minimum that fits as well, more than 3 sigma away). Near 1
  // (0.3-1 measured) when sigma describes the fit; near 0 when the cost is flat or has a
  // second minimum in D (a bar about as wide as a small blur: width and blur trade off).
  double diameter_profile_ratio = 1;
  EdgeLine line_a, line_b;   // fitted, in the order given (a: the first guess)
  double separation_px = 0;  // between the lines at line a's point, along its normal
  double level_0 = 0, level_1 = 0, level_2 = 0;  // before the first line, between, after
  double rms_residual = 0;
  double contrast_to_noise = 0;  // the smaller step |L1 - L0|, |L2 - L1| over rms
  int samples = 0, iterations = 0;
};

// Errors: kErrInvalidArgument (image type, non-finite guesses, window sizes, lines more
// than 15 degrees from parallel or coinciding), kErrWindowOutsideImage, kErrTooFewPixels,
// kErrNoContrast, kErrWindowTooSmall (the window does not hold D/2 + 2 px beyond each
// fitted line), kErrNotConverged, "lines_crossed" (the fit put the lines on top of or
// through each other: no pair of edges in the data).
Result<EdgePairFit> fit_pillbox_edge_pair(const cv::Mat& image, const EdgeLine& guess_a,
                                          const EdgeLine& guess_b,
                                          const EdgePairFitOptions& options);

}  // namespace camlab::analysis
