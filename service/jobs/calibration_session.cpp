#include "service/jobs/calibration_session.h"

#include <chrono>
#include <cmath>

#include "base/atomic_file.h"
#include "calib/corners/corners_vnl.h"
#include "calib/guided_session.h"
#include "calib/lens_model.h"

namespace camlab::service {

namespace {

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

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
    // The loop's model (see the header); configured for this imager.
    const bool fixed =
        options_.model != "auto" && options_.model.find("SPLINED") == std::string::npos;
    auto configured = calib::configured_lensmodel(fixed ? options_.model : "LENSMODEL_OPENCV8",
                                                  image.cols, image.rows, 90);
    if (!configured) return configured.error();
    loop_model_ = *configured;
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
  if (view && view->present_count() >= 8) {
    view->name = frame_file;
    record.board_found = true;
    record.corners = view->present_count();
    record.view = static_cast<int>(data_.views.size());
    data_.views.push_back(std::move(*view));
  } else {
    last_error_ =
        make_error("board_not_found",
                   "no board found in the frame of capture job " + std::to_string(capture_job) +
                       ": check that the whole board is in view, in focus and well "
                       "exposed");
  }
  frames_.push_back(record);
  if (record.board_found) solve_and_suggest();
  return {};
}

void CalibrationSession::solve_and_suggest() {
  calib::SuggestionOptions suggest;
  suggest.whole_board_required = !calib::detector_keeps_partial_boards(options_.detector);
  const auto solve_start = std::chrono::steady_clock::now();
  solution_.reset();
  coverage_.reset();
  if (data_.views.size() >= 2) {
    calib::SolveOptions solve;
    solve.lensmodel = loop_model_;
    solve.board_warp = options_.board_warp;
    // Warm start from the previous solve: its poses for the views it had, PnP for the new.
    if (previous_) solve.warm_start = calib::session_warm_start(*previous_);
    auto solved = calib::solve(data_, solve);
    if (solved) {
      solution_ = std::move(*solved);
      previous_ = solution_;
    } else {
      last_error_ = solved.error();
    }
  }
  last_solve_s_ = seconds_since(solve_start);
  const auto suggest_start = std::chrono::steady_clock::now();
  if (solution_) {
    if (auto c = calib::uncertainty_coverage(*solution_, suggest); c)
      coverage_ = std::move(*c);
    else
      last_error_ = c.error();
  }
  auto next = calib::suggest_next_view(data_, solution_ ? &*solution_ : nullptr, suggest);
  if (next)
    suggestion_ = std::move(*next);
  else
    last_error_ = next.error();
  last_suggest_s_ = seconds_since(suggest_start);
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
                      {"corners", f.corners}});
  nlohmann::json json = {
      {"frames", frames},          {"views_with_board", data_.views.size()},
      {"loop_model", loop_model_}, {"target_uncertainty_px", target_uncertainty_px_},
      {"solve_s", last_solve_s_},  {"suggest_s", last_suggest_s_}};
  if (data_.imager_width_px > 0)
    json["imager_px"] = {data_.imager_width_px, data_.imager_height_px};
  json["solution"] = nullptr;
  if (solution_)
    json["solution"] = {{"rms_px", solution_->rms_px},
                        {"worst_px", solution_->worst_px},
                        {"inliers", solution_->inliers},
                        {"outliers", solution_->outliers},
                        {"views_used", solution_->views_used.size()},
                        {"intrinsics", solution_->model.intrinsics}};
  json["uncertainty"] = nullptr;
  json["target_reached"] = false;
  if (coverage_) {
    nlohmann::json grid = nlohmann::json::array();
    for (double v : coverage_->worst_px) grid.push_back(finite_or_null(v));
    json["uncertainty"] = {{"distance_m", coverage_->distance_m},
                           {"worst_px", finite_or_null(coverage_->worst_of_grid_px)},
                           {"worst_at_px", {coverage_->worst_x_px, coverage_->worst_y_px}},
                           {"grid_cols", coverage_->cols},
                           {"grid_rows", coverage_->rows},
                           {"grid_worst_px", grid}};
    json["target_reached"] = std::isfinite(coverage_->worst_of_grid_px) &&
                             coverage_->worst_of_grid_px <= target_uncertainty_px_;
  }
  json["suggestion"] = suggestion_ ? calib::to_json(*suggestion_) : nlohmann::json(nullptr);
  json["last_error"] = last_error_ ? nlohmann::json{{"code", name_of(last_error_->code)},
                                                    {"message", last_error_->message}}
                                   : nlohmann::json(nullptr);
  return json;
}

}  // namespace camlab::service
