// A guided calibration over a folder of images that grows (`camlab calibrate --watch`).
// Each poll lists the folder and detects the board in the images it has not seen; an
// image is read once its size has stayed the same over two polls, so a copy in progress
// is not read half-written. When views were added, the guided loop (guided_loop.h, the
// same as camlabd's sessions) re-solves and suggests the next view.
//
// Thread-compatible.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "base/result.h"
#include "calib/calibrate.h"
#include "calib/guided_loop.h"
#include "calib/solver.h"
#include "calib/view_suggestion.h"

namespace camlab::calib {

// Every field of a suggestion, and a coverage's summary (its grid too, row-major), as
// JSON objects (`camlab calibrate --suggest --json`, `--watch --json`).
nlohmann::json to_json(const ViewSuggestion& suggestion);
nlohmann::json to_json(const UncertaintyCoverage& coverage);

struct FolderPoll {
  int new_images = 0;                           // images detected in this poll
  int new_views = 0;                            // of them, those with the board
  std::vector<std::string> skipped;             // "name: why" for images that cannot be used
  bool solved = false;                          // a solve with a covariance ran in this poll
  std::string solve_error;                      // why there is no solution yet (too few views, ...)
  std::optional<UncertaintyCoverage> coverage;  // of the last solution
  std::optional<ViewSuggestion> suggestion;     // after a poll with new images: the next view
  std::string suggestion_error;
};

class FolderSession {
 public:
  // `options`: images_dir (required), board, detector and its ChArUco fields, model
  // ("auto" solves LENSMODEL_OPENCV8: model selection cross-validates, too slow for every
  // view), imager, focal_guess_px, board_warp, pixel pitch or sensor for the report.
  // Errors: "invalid_argument" (no folder, a bad board or detector, suggestion options).
  static Result<FolderSession> open(CalibrateOptions options, SuggestionOptions suggestion);

  // Detects the new images; re-solves and suggests when views were added.
  Result<FolderPoll> poll();

  int images() const { return images_; }
  const CalibrationData& data() const { return data_; }
  const Solution* solution() const { return loop_ ? loop_->solution() : nullptr; }

  // The run for write_calibration_outputs (calibrate.h): the report, the .cameramodel
  // with mrcal's optimization inputs, OpenCV YAML when the model has one. Error
  // "too_few_views" before the first solve.
  Result<CalibrationRun> run() const;

 private:
  CalibrateOptions options_;
  SuggestionOptions suggestion_;
  CalibrationData data_;
  int images_ = 0;
  std::map<std::string, long long> pending_size_;  // name -> size at the last poll
  std::map<std::string, bool> seen_;               // name -> detected (or skipped)
  std::optional<GuidedLoop> loop_;  // from the first view (the loop's model needs the imager)
  std::optional<ViewSuggestion> last_suggestion_;
};

}  // namespace camlab::calib
