#include "service/jobs/calibration_session.h"

#include <cmath>

#include "base/atomic_file.h"
#include "calib/corners/corners_vnl.h"
#include "calib/guided_loop.h"
#include "calib/guided_session.h"
#include "calib/view_novelty.h"

namespace camlab::service {

namespace {

// A number for JSON: NaN and infinities (a grid point the model cannot unproject) as null.
nlohmann::json finite_or_null(double value) {
  return std::isfinite(value) ? nlohmann::json(value) : nlohmann::json(nullptr);
}

}  // namespace

CalibrationSession::CalibrationSession(calib::CalibrateOptions options,
                                       double target_uncertainty_px)
    : options_(std::move(options)), target_uncertainty_px_(target_uncertainty_px) {
  data_.board = options_.board;
}

Status CalibrationSession::add_frame(const cv::Mat& image, int64_t capture_job,
                                     const std::string& frame_file) {
  if (data_.imager_width_px == 0) {
    data_.imager_width_px = image.cols;
    data_.imager_height_px = image.rows;
    // The loop's model (calib/guided_loop.h), configured for this imager.
    calib::GuidedLoopOptions loop;
    auto configured = calib::guided_loop_model(options_.model, image.cols, image.rows);
    if (!configured) return configured.error();
    loop.lensmodel = *configured;
    loop.focal_guess_px = options_.focal_guess_px;
    loop.board_warp = options_.board_warp;
    loop.suggestion.whole_board_required = !calib::detector_keeps_partial_boards(options_.detector);
    loop_.emplace(std::move(loop));
  } else if (image.cols != data_.imager_width_px || image.rows != data_.imager_height_px) {
    return make_error("imager_mismatch", "the frame is " + std::to_string(image.cols) + "x" +
                                             std::to_string(image.rows) +
                                             "; the session's first was " +
                                             std::to_string(data_.imager_width_px) + "x" +
                                             std::to_string(data_.imager_height_px));
  }
  FrameRecord record{capture_job, frame_file};
  last_error_.reset();
  auto view = calib::detect_board_view(image, options_);
  std::optional<calib::NearDuplicate> duplicate;
  if (view && view->present_count() >= 8) {
    view->name = frame_file;
    record.board_found = true;
    record.corners = view->present_count();
    duplicate = calib::find_near_duplicate(data_, *view);
    if (duplicate) {
      record.duplicate_of = duplicate->view;
      last_error_ = make_error("duplicate_view", "view not taken: " + describe(*duplicate, data_));
    } else {
      record.view = static_cast<int>(data_.views.size());
      data_.views.push_back(std::move(*view));
    }
  } else {
    last_error_ =
        make_error("board_not_found",
                   "no board found in the frame of capture job " + std::to_string(capture_job) +
                       ": check that the whole board is in view, in focus and well "
                       "exposed");
  }
  frames_.push_back(record);
  // A refused view changes nothing: the solve and the suggestion stand (the suggestion is
  // still the pose to take).
  if (record.view >= 0) solve_and_suggest();
  return {};
}

void CalibrationSession::solve_and_suggest() {
  calib::GuidedStep step = loop_->step(data_);
  // Before the second view there is nothing to solve: not an error of the view just added.
  if (step.solve_error && step.solve_error->code != ErrorCode::kTooFewViews)
    last_error_ = step.solve_error;
  if (step.suggestion_error) last_error_ = step.suggestion_error;
  suggestion_ = std::move(step.suggestion);
  last_solve_s_ = step.solve_s;
  last_suggest_s_ = step.suggest_s;
}

Result<nlohmann::json> CalibrationSession::finish(const std::filesystem::path& out_dir,
                                                  double pixel_pitch_um) {
  if (data_.views.size() < 2)
    return make_error("too_few_views", "the session has " + std::to_string(data_.views.size()) +
                                           " view(s) with a board; a calibration needs 2 or more "
                                           "(take more views first)");
  std::error_code ec;
  std::filesystem::create_directories(out_dir, ec);
  if (ec) return make_error("io_error", "cannot create the session's folder: " + ec.message());
  const std::filesystem::path corners = out_dir / "corners.vnl";
  if (Status s = write_file_atomically(corners, calib::to_corners_vnl(data_.views)); !s)
    return s.error();
  calib::CalibrateOptions options = options_;
  options.corners_vnl = corners;
  options.imager_width_px = data_.imager_width_px;
  options.imager_height_px = data_.imager_height_px;
  options.pixel_pitch_um = pixel_pitch_um;
  options.out_cameramodel = out_dir / "camera.cameramodel";
  options.out_report_json = out_dir / "report.json";
  return calib::calibrate_folder(options);
}

nlohmann::json CalibrationSession::to_json() const {
  nlohmann::json frames = nlohmann::json::array();
  for (const auto& f : frames_)
    frames.push_back({{"capture_job", f.capture_job},
                      {"frame", f.frame_file},
                      {"board_found", f.board_found},
                      {"corners", f.corners},
                      {"view", f.view >= 0 ? nlohmann::json(f.view) : nlohmann::json(nullptr)},
                      {"duplicate_of", f.duplicate_of >= 0 ? nlohmann::json(f.duplicate_of)
                                                           : nlohmann::json(nullptr)}});
  nlohmann::json json = {{"frames", frames},
                         {"views_with_board", data_.views.size()},
                         {"loop_model", loop_ ? loop_->options().lensmodel : ""},
                         {"target_uncertainty_px", target_uncertainty_px_},
                         {"solve_s", last_solve_s_},
                         {"suggest_s", last_suggest_s_}};
  if (data_.imager_width_px > 0)
    json["imager_px"] = {data_.imager_width_px, data_.imager_height_px};
  // The last solve with a covariance (a later one that failed says so in last_error).
  const calib::Solution* solution = loop_ ? loop_->solution() : nullptr;
  const calib::UncertaintyCoverage* coverage = loop_ ? loop_->coverage() : nullptr;
  json["solution"] = nullptr;
  if (solution)
    json["solution"] = {{"rms_px", solution->rms_px},
                        {"worst_px", solution->worst_px},
                        {"inliers", solution->inliers},
                        {"outliers", solution->outliers},
                        {"views_used", solution->views_used.size()},
                        {"intrinsics", solution->model.intrinsics}};
  json["uncertainty"] = nullptr;
  json["target_reached"] = false;
  if (coverage) {
    nlohmann::json grid = nlohmann::json::array();
    for (double v : coverage->worst_px) grid.push_back(finite_or_null(v));
    json["uncertainty"] = {{"distance_m", coverage->distance_m},
                           {"worst_px", finite_or_null(coverage->worst_of_grid_px)},
                           {"worst_at_px", {coverage->worst_x_px, coverage->worst_y_px}},
                           {"grid_cols", coverage->cols},
                           {"grid_rows", coverage->rows},
                           {"grid_worst_px", grid}};
    json["target_reached"] = loop_->target_reached(target_uncertainty_px_);
  }
  json["suggestion"] = suggestion_ ? calib::to_json(*suggestion_) : nlohmann::json(nullptr);
  json["last_error"] = last_error_ ? nlohmann::json{{"code", name_of(last_error_->code)},
                                                    {"message", last_error_->message}}
                                   : nlohmann::json(nullptr);
  return json;
}

}  // namespace camlab::service
