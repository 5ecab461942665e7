// The calibration report: what the solution says (intrinsics, FOV by unprojecting the
// image edges, focal length in mm and its 35-mm equivalent when the pixel pitch is known,
// residuals, outliers) and how far the data supports it (coverage of the imager, range of
// board tilts, board sizes, the projection uncertainty at the centre and corners from
// the solution's Jacobian: uncertainty.h), with warnings that have stable codes:
//
//   too_few_views     fewer than 8 views solved
//   fronto_parallel   every board within 12 deg of facing the camera (its line of sight),
//                     or of parallel to the image plane: focal length and distance trade
//                     off, the focal length is poorly constrained
//   centre_only       corners cover less than a third of the imager's outer ring
//   far_boards        boards span under a quarter of the imager's diagonal (median)
//   many_outliers     more than 5% of the corners were rejected
//   high_residuals    inlier RMS above 1 px, each corner weighted by its detection level:
//                     the model cannot describe the lens or the corners are poor
//   fov_undefined     the model does not invert at some image edges: the message names the
//                     FOV (horizontal, vertical, diagonal) that is missing
//   implausible_intrinsics  fx/fy outside 0.8-1.25 or the principal point off the imager
//
// Reentrant.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "calib/calibration_data.h"
#include "calib/intrinsics_uncertainty.h"
#include "calib/lens_model.h"
#include "calib/repeatability.h"
#include "calib/solver.h"
#include "calib/uncertainty.h"

namespace camlab::calib {

struct Warning {
  std::string code;
  std::string message;  // what is wrong and what to capture next
};

// One row of the model-selection evidence table.
struct ModelEvidence {
  std::string lensmodel;
  int params = 0;
  double rms_px = 0;
  double heldout_px = 0;  // trimmed RMS on held-out data (model_selection.h)
  double solve_s = 0;     // the solve on all views
  double cv_s = 0;        // the cross-validation folds
  bool ok = false;
  std::string error;
  std::string note;  // a check that is not a cross-validated candidate (the spline cross-check)
};

// The spline cross-check of `--model auto` (model_selection.cpp): whether it ran, the
// residual-pattern statistic that decides it (residual_pattern.h), and why, in words.
struct SplineCheck {
  bool considered = false;  // false: not a model selection, or held out by corners
  bool ran = false;
  double residual_pattern_score = 0;  // cells z + neighbour z (residual_pattern.h)
  std::string reason;
};

struct CalibrationReport {
  Solution solution;
  FieldOfViewParts fov;  // each FOV where the model inverts at its edge points
  // 1-sigma of fx, fy, cx, cy and the FOVs from corner noise; empty without a covariance.
  std::optional<IntrinsicsUncertainty> intrinsics_sigma;
  double pixel_pitch_um = 0;  // 0: unknown
  double focal_mm = 0, focal_35mm_equiv_mm = 0, crop_factor = 0;
  int views_total = 0;
  double rms_weighted_px = 0;  // inlier RMS of weight x residual (mrcal's x), px at level 0
  double outlier_share = 0;
  double coverage = 0;       // share of a 16 x 10 grid of imager cells holding an inlier
  double edge_coverage = 0;  // the same over the outer ring of cells
  double tilt_min_deg = 0, tilt_max_deg = 0;              // board normal off the line of sight
  double tilt_plane_min_deg = 0, tilt_plane_max_deg = 0;  // board normal off the optical axis
  double board_span_median = 0;  // board extent / imager diagonal, median over views
  std::optional<UncertaintySummary> uncertainty;  // empty: uncertainty_error says why
  std::string uncertainty_error;
  std::vector<ModelEvidence> evidence;
  std::string cross_validation;  // how held-out errors were found: "views", "corners" or ""
  SplineCheck spline_check;
  // Odd/even and leave-one-out (repeatability.h); empty when not measured (a corners.vnl
  // without views, --no-repeatability) or when it failed (repeatability_error says why).
  std::optional<Repeatability> repeatability;
  std::string repeatability_error;
  std::vector<Warning> warnings;
};

// Builds the report. pixel_pitch_um <= 0: no mm figures.
CalibrationReport make_report(const CalibrationData& data, const Solution& solution,
                              double pixel_pitch_um);

bool has_warning(const CalibrationReport& report, const std::string& code);

nlohmann::json to_json(const CalibrationReport& report);
std::string to_text(const CalibrationReport& report);

}  // namespace camlab::calib
