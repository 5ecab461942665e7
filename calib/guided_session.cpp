#include "calib/guided_session.h"
#include "calib/view_novelty.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <system_error>

#include <unistd.h>

#include "base/atomic_file.h"
#include "calib/calibration_request.h"
#include "calib/corners/corners_vnl.h"
#include "calib/guided_loop.h"
#include "calib/model_io.h"
#include "calib/report.h"
#include "optics/optics.h"

namespace camlab::calib {

namespace fs = std::filesystem;

nlohmann::json to_json(const ViewSuggestion& s) {
  return {{"rt_cam_board", s.rt_cam_board},
          {"centre_x_px", s.centre_x_px},
          {"centre_y_px", s.centre_y_px},
          {"bounds_px", s.bounds_px},
          {"outline_px", s.outline_px},
          {"imager_px", {s.imager_width_px, s.imager_height_px}},
          {"distance_m", s.distance_m},
          {"tilt_about_x_deg", s.tilt_about_x_deg},
          {"tilt_about_y_deg", s.tilt_about_y_deg},
          {"region", s.region},
          {"description", s.description},
          {"worst_now_px", s.worst_now_px},
          {"predicted_worst_px", s.predicted_worst_px},
          {"opening", s.opening}};
}

nlohmann::json to_json(const UncertaintyCoverage& c) {
  nlohmann::json grid = nlohmann::json::array();
  for (double v : c.worst_px)
    grid.push_back(std::isfinite(v) ? nlohmann::json(v) : nlohmann::json());
  return {{"cols", c.cols},
          {"rows", c.rows},
          {"distance_m", c.distance_m},
          {"worst_of_grid_px", c.worst_of_grid_px},
          {"worst_x_px", c.worst_x_px},
          {"worst_y_px", c.worst_y_px},
          {"worst_px", grid}};
}

Result<FolderSession> FolderSession::open(CalibrateOptions options, SuggestionOptions suggestion) {
  if (options.images_dir.empty() || !options.job_dir.empty() || !options.corners_vnl.empty())
    return make_error("invalid_argument", "watching needs a folder of images and no other source");
  std::error_code ec;
  if (!fs::is_directory(options.images_dir, ec))
    return make_error("invalid_argument",
                      "'" + options.images_dir.string() + "' is not a folder to watch");
  if (Status checked = check_calibration_request(options); !checked) return checked.error();
  FolderSession s;
  s.options_ = std::move(options);
  s.suggestion_ = suggestion;
  s.data_.board = s.options_.board;
  s.data_.imager_width_px = s.options_.imager_width_px;
  s.data_.imager_height_px = s.options_.imager_height_px;
  // The detector and the suggestion options are checked before any image arrives.
  CalibrationData shape = s.data_;
  shape.imager_width_px = shape.imager_height_px = 1000;
  if (auto check = suggest_next_view(shape, nullptr, suggestion);
      !check && check.error().code == ErrorCode::kInvalidArgument)
    return check.error();
  return s;
}

Result<FolderPoll> FolderSession::poll() {
  FolderPoll out;
  std::vector<fs::path> ready;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(options_.images_dir, ec)) {
    if (!e.is_regular_file(ec) || !is_calibration_image(e.path())) continue;
    const std::string name = e.path().filename().string();
    if (seen_.count(name)) continue;
    const long long size = static_cast<long long>(e.file_size(ec));
    if (ec) continue;
    auto it = pending_size_.find(name);
    if (it != pending_size_.end() && it->second == size && size > 0)
      ready.push_back(e.path());
    else
      pending_size_[name] = size;
  }
  if (ec)
    return make_error("io_error",
                      "cannot list '" + options_.images_dir.string() + "': " + ec.message());
  std::sort(ready.begin(), ready.end());
  for (const auto& path : ready) {
    const std::string name = path.filename().string();
    pending_size_.erase(name);
    seen_[name] = true;
    ++images_;
    ++out.new_images;
    int w = 0, h = 0;
    auto view = detect_image_view(path, options_, &w, &h);
    if (!view) {
      if (view.error().code != ErrorCode::kIoError) return view.error();
      out.skipped.push_back(name + ": " + view.error().message);
      continue;
    }
    if (data_.imager_width_px == 0) {
      data_.imager_width_px = w;
      data_.imager_height_px = h;
    } else if (w != data_.imager_width_px || h != data_.imager_height_px) {
      out.skipped.push_back(name + ": " + std::to_string(w) + "x" + std::to_string(h) +
                            ", not the session's " + std::to_string(data_.imager_width_px) + "x" +
                            std::to_string(data_.imager_height_px));
      continue;
    }
    if (!*view) continue;
    if (auto duplicate = find_near_duplicate(data_, **view)) {
      out.skipped.push_back(name + ": " + describe(*duplicate, data_));
      continue;
    }
    data_.views.push_back(std::move(**view));
    ++out.new_views;
  }
  if (out.new_views == 0) {
    if (loop_ && loop_->coverage()) out.coverage = *loop_->coverage();
    // Images without a new view (no board, a repeat) leave the next pose to take as it was.
    if (out.new_images > 0) out.suggestion = last_suggestion_;
    return out;
  }
  if (!loop_) {
    GuidedLoopOptions o;
    CAMLAB_ASSIGN(o.lensmodel,
                  guided_loop_model(options_.model, data_.imager_width_px, data_.imager_height_px));
    o.focal_guess_px = options_.focal_guess_px;
    o.board_warp = options_.board_warp;
    o.suggestion = suggestion_;
    loop_.emplace(std::move(o));
  }
  GuidedStep step = loop_->step(data_);
  out.solved = step.solved;
  if (step.solve_error) out.solve_error = step.solve_error->message;
  if (loop_->coverage()) out.coverage = *loop_->coverage();
  out.suggestion = std::move(step.suggestion);
  last_suggestion_ = out.suggestion;
  if (step.suggestion_error) out.suggestion_error = step.suggestion_error->text();
  return out;
}

Result<CalibrationRun> FolderSession::run() const {
  const Solution* solution = this->solution();
  if (!solution)
    return make_error("too_few_views", "no solve yet: the folder holds too few views of the board");
  if (!guided_loop_solves(options_.model)) {
    // The loop solved LENSMODEL_OPENCV8 (guided_loop_model); the finish is the full
    // calibration on the views, as camlabd's sessions finish: model selection, or the spline.
    CalibrateOptions o = options_;
    o.images_dir.clear();
    o.corners_vnl =
        fs::temp_directory_path() / ("camlab-watch-" + std::to_string(::getpid()) + "-corners.vnl");
    o.imager_width_px = data_.imager_width_px;
    o.imager_height_px = data_.imager_height_px;
    if (Status s = write_file_atomically(o.corners_vnl, to_corners_vnl(data_.views)); !s)
      return s.error();
    auto finished = calibrate(o);
    std::error_code ec;
    fs::remove(o.corners_vnl, ec);
    if (finished) {
      finished->images = images_;
      finished->report_json["images"] = images_;
    }
    return finished;
  }
  CalibrationRun run;
  run.data = data_;
  run.images = images_;
  double pitch_um = options_.pixel_pitch_um;
  if (!options_.sensor.empty()) {
    optics::SensorFormat format;
    CAMLAB_ASSIGN(format, optics::find_sensor_format(options_.sensor));
    pitch_um = format.width_mm * 1000.0 / data_.imager_width_px;
  }
  run.report = make_report(data_, *solution, pitch_um);
  run.report_json = to_json(run.report);
  run.report_json["images"] = images_;
  CAMLAB_ASSIGN(run.cameramodel_text,
                cameramodel_text_with_inputs(
                    *solution, data_, "camlab calibrate --watch: " + loop_->options().lensmodel));
  if (has_opencv_equivalent(solution->model))
    if (auto yaml = opencv_yaml_text(solution->model); yaml.ok())
      run.opencv_yaml_text = std::move(*yaml);
  return run;
}

}  // namespace camlab::calib
