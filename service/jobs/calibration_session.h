// One guided calibration: the views taken so far and, after each, the guided loop
// (calib/guided_loop.h, the same as `camlab calibrate --watch`): the solve, the projection
// uncertainty over the imager and the next suggested view; finished into a .cameramodel
// and a report by the same run as POST /v1/calibrations (calib/calibrate.h), from the
// session's corners, with the request's model ("auto" included).
//
// Not thread-safe: the session manager (calibration_sessions.h) owns each session and
// works on it from its one thread; readers get the JSON snapshot it publishes.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "base/result.h"
#include "calib/calibrate.h"
#include "calib/guided_loop.h"
#include "calib/solver.h"
#include "calib/view_suggestion.h"

namespace camlab::service {

class CalibrationSession {
 public:
  // `options` from calibration_options() (board, detector, model); the target is the
  // worst-of-grid uncertainty (px, at the working distance) at which the session says
  // it has enough views.
  CalibrationSession(calib::CalibrateOptions options, double target_uncertainty_px);

  // Detects the board in `image` (a frame's luminance) and, when found, solves and
  // suggests again. A frame without a board is recorded (board_found false) and is not an
  // error. Errors: "imager_mismatch" (a frame of another size than the first).
  // `capture_job` names the frame in the state.
  Status add_frame(const cv::Mat& image, int64_t capture_job, const std::string& frame_file);

  // A view that could not be taken (the capture failed): kept in the state as the last
  // error, with no view added.
  void note_error(const Error& error) { last_error_ = error; }

  // Writes corners.vnl into `out_dir` and runs the full calibration from it (the
  // request's model, "auto" included), writing camera.cameramodel and report.json there.
  // Returns the report as written. Errors: "too_few_views" and those of calibrate().
  Result<nlohmann::json> finish(const std::filesystem::path& out_dir, double pixel_pitch_um);

  // The state as the API shows it (docs/service.md, "Guided calibration").
  nlohmann::json to_json() const;

  int views_found() const { return static_cast<int>(data_.views.size()); }

 private:
  void solve_and_suggest();

  calib::CalibrateOptions options_;
  double target_uncertainty_px_;
  calib::CalibrationData data_;
  struct FrameRecord {
    int64_t capture_job = 0;
    std::string frame_file;
    bool board_found = false;
    int corners = 0;
    int view = -1;          // index into data_.views when taken
    int duplicate_of = -1;  // the view it repeats, when refused as a near-duplicate
  };
  std::vector<FrameRecord> frames_;
  std::optional<calib::GuidedLoop> loop_;  // from the first frame (its model needs the imager)
  std::optional<calib::ViewSuggestion> suggestion_;
  std::optional<Error> last_error_;
  double last_solve_s_ = 0, last_suggest_s_ = 0;
};

}  // namespace camlab::service
