// Whether a solution's residuals hold a pattern: the test that decides whether
// `--model auto` runs its spline cross-check (model_selection.cpp uses z + neighbour_z).
//
// A lens model that cannot describe the lens leaves residuals that agree in direction
// wherever the boards crossed the same part of the imager; noise does not. The inlier
// residuals, each times its corner's weight (so in units of its own noise, as mrcal's
// measurements are), are binned by the observed corner's position into an 8 x 5 grid of
// imager cells. Without a pattern, n |mean|^2 / sigma^2 of a cell of n residuals is
// chi-square with 2 degrees of freedom (sigma^2: the mean square per coordinate over all
// inliers), and their sum T over the K cells holding 2+ residuals is chi-square with 2K:
// the result is z = (T - 2K) / sqrt(4K), about 0 +- 1 for noise and far above it for a
// misfit (tests/unit/calib/residual_pattern_test.cpp). Pose fits absorb part of any
// pattern, and of the noise too, so z runs slightly below 0 on pure noise.
//
// Reentrant.
#pragma once

#include "calib/calibration_data.h"
#include "calib/solver.h"

namespace camlab::calib {

struct ResidualPattern {
  double z = 0;  // (T - 2K) / sqrt(4K); 0 when there are too few residuals
  // Neighbour correlation: over pairs of adjacent corners of one view (along a row or a
  // column), the sum of the dot products of their weighted residuals over the square root
  // of the sum of their squares: about 0 +- 1 for independent noise, high for a misfit
  // that is smooth within views even where it differs from view to view.
  double neighbour_z = 0;
  int cells = 0;  // K
  int residuals = 0;
};

ResidualPattern residual_pattern(const CalibrationData& data, const Solution& solution);

}  // namespace camlab::calib
