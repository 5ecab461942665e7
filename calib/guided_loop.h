// The guided calibration's one loop, shared by `camlab calibrate --watch` (guided_session.h)
// and camlabd's calibration sessions (service/jobs/calibration_session.h): after views were
// added, a solve warm-started from the last good one (cold when the warm start fails: an
// early solution can be a poor start), kept only when it has a covariance (the uncertainty
// needs it), the projection uncertainty over the imager, and the next suggested view
// (view_suggestion.h). The opening sequence is suggested until a solve has a covariance.
//
// Thread-compatible.
#pragma once

#include <optional>
#include <string>

#include "base/result.h"
#include "calib/calibration_data.h"
#include "calib/solver.h"
#include "calib/view_suggestion.h"

namespace camlab::calib {

// The model the loop solves, configured for the imager: the requested one, or
// LENSMODEL_OPENCV8 for "auto" and the splined models (model selection cross-validates and
// a spline solves slowly; both are left to the finish, which runs once on every view).
Result<std::string> guided_loop_model(const std::string& requested_model, int imager_width_px,
                                      int imager_height_px);

// Whether the loop solves the requested model itself; when not, a session's end is the full
// calibration on its views with the requested model.
bool guided_loop_solves(const std::string& requested_model);

struct GuidedLoopOptions {
  std::string lensmodel;      // configured mrcal name (guided_loop_model)
  double focal_guess_px = 0;  // > 0: passed to every solve (SolveOptions::focal_guess_px)
  bool board_warp = true;
  SuggestionOptions suggestion;
};

struct GuidedStep {
  bool solved = false;                       // this step's solve has a covariance: kept
  std::optional<Error> solve_error;          // why not (too few views, no covariance, ...)
  std::optional<Error> suggestion_error;     // why there is no suggestion
  std::optional<ViewSuggestion> suggestion;  // the next view to take
  double solve_s = 0, suggest_s = 0;         // wall time of each part
};

class GuidedLoop {
 public:
  explicit GuidedLoop(GuidedLoopOptions options) : options_(std::move(options)) {}

  // Solves `data` (which gained views since the last step) and suggests the next view.
  // Never fails: what could not be done is in the step's errors, and the last good
  // solution and its coverage stay.
  GuidedStep step(const CalibrationData& data);

  // The solve and the coverage of step(), without the suggestion: for a loop that takes
  // its views where it likes (random poses, in the tests and benchmarks).
  GuidedStep resolve(const CalibrationData& data);

  // The last solve with a covariance, and its uncertainty over the imager; null before one.
  const Solution* solution() const { return solution_ ? &*solution_ : nullptr; }
  const UncertaintyCoverage* coverage() const { return coverage_ ? &*coverage_ : nullptr; }

  // Whether the coverage's worst uncertainty is at or below `target_px` (> 0).
  bool target_reached(double target_px) const;

  const GuidedLoopOptions& options() const { return options_; }

 private:
  GuidedLoopOptions options_;
  std::optional<Solution> solution_;
  std::optional<UncertaintyCoverage> coverage_;
};

}  // namespace camlab::calib
