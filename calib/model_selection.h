// Model selection (`--model auto`): fit models of growing richness, score each by
// cross-validation over views (fit on the other views, refit only the poses of the
// held-out ones with the lens fixed, trimmed RMS of their residuals), and keep the
// simplest model that a richer one does not beat by more than 5% (and 0.005 px) on
// held-out views. Models are compared by their projections of held-out data, never by
// coefficients. The search stops after two richer models in a row fail to improve.
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
};

// PINHOLE, OPENCV4, OPENCV5, OPENCV8, OPENCV12.
std::vector<std::string> default_candidate_models();

// `options.lensmodel` is ignored; `folds` >= 2 (fewer when there are few views).
Result<ModelSelection> select_model(const CalibrationData& data, const SolveOptions& options,
                                    const std::vector<std::string>& candidates, int folds = 3);

}  // namespace camlab::calib
