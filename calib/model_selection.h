// Model selection (`--model auto`): fit models of growing richness, score each by
// cross-validation over views (fit on the other views, refit only the poses of the
// held-out ones with the lens fixed; residuals times the corners' weights, so each is in
// units of its own noise), and keep the simplest model that a richer one does not beat
// significantly on the held-out corners: a paired test per held-out view, the mean gain
// more than 3 standard errors (model_selection.cpp). The evidence table's heldout_px is
// the trimmed RMS of the weighted held-out residuals. Models are compared by their
// projections of held-out data, never by coefficients. The search stops after two
// richer models in a row fail to improve.
// A fisheye (corners seen 60 deg or more off the axis, or a chosen model that sees 120 deg
// or more across or has no defined FOV) gets two more candidates, fitted and judged the
// same way: LENSMODEL_STEREOGRAPHIC, then mrcal's splined stereographic model over the
// field the fits see. One is also taken when the model chosen so far has no horizontal
// FOV and its held-out error is within 10%: the field of view is the number asked for.
// With fewer than 6 usable views no view can be spared: a third of each view's corners
// is held out per fold instead (cross_validation "corners"; weaker evidence, see
// model_selection.cpp), and the report says so.
//
// Reentrant.
#pragma once

#include <string>
#include <vector>

#include "base/result.h"
#include "calib/calibration_data.h"
#include "calib/report.h"
#include "calib/solver.h"

namespace camlab::calib {

struct ModelSelection {
  Solution chosen;
  std::vector<ModelEvidence> evidence;  // in the order tried
  std::string cross_validation;         // "views" or "corners"
  SplineCheck spline_check;             // whether the spline cross-check ran, and why
};

// PINHOLE, OPENCV4, OPENCV5, OPENCV8, OPENCV12.
//
// Candidates are fitted and cross-validated on up to `threads` threads (0: the hardware's,
// at most 4), in order, each from its own seed: the choice is the same for any thread count.
std::vector<std::string> default_candidate_models();

// `options.lensmodel` is ignored; `folds` >= 2 (fewer when there are few views).
Result<ModelSelection> select_model(const CalibrationData& data, const SolveOptions& options,
                                    const std::vector<std::string>& candidates, int folds = 3,
                                    int threads = 0);

}  // namespace camlab::calib
