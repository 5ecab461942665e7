#include "service/compute_jobs.h"

#include <opencv2/core.hpp>

#include "analysis/defocus_report.h"
#include "analysis/exposure_report.h"
#include "analysis/focus_report.h"
#include "calib/chessboard_corners.h"
#include "calib/lens_model.h"
#include "calib/model_io.h"
#include "calib/model_selection.h"
#include "calib/report.h"
#include "calib/solver.h"
#include "image/atomic_file.h"
#include "image/capture_folder.h"
#include "service/log.h"
#include "service/metrics.h"

namespace camlab::service {

namespace {

JobOutcome failure(Error error) {
  JobOutcome outcome;
  outcome.state = JobState::kFailed;
  outcome.error = std::move(error);
  return outcome;
}

// The pixel pitch a capture's manifest knows (the virtual camera's spec), else 0.
double manifest_pixel_pitch_um(const image::CaptureFolder& folder) {
  const nlohmann::json& source = folder.manifest().value("source", nlohmann::json::object());
  if (source.is_object() && source.contains("camera_spec")) {
    const auto& sensor = source["camera_spec"].value("sensor", nlohmann::json::object());
    if (sensor.is_object() && sensor.contains("pixel_pitch_um") && sensor["pixel_pitch_um"].is_number())
      return sensor["pixel_pitch_um"].get<double>();
  }
  return 0;
}

}  // namespace

JobOutcome execute_calibration(const JobRecord& job, const std::filesystem::path& data_dir) {
  const nlohmann::json& request = job.request;
  auto folder = image::CaptureFolder::open(data_dir / request.at("source_folder").get<std::string>());
  if (!folder) return failure(folder.error());

  calib::CalibrationData data;
  data.board.cols = request.at("inner_corners").at(0).get<int>();
  data.board.rows = request.at("inner_corners").at(1).get<int>();
  data.board.spacing_m = request.at("spacing_m").get<double>();
  int images = 0;
  for (size_t i = 0; i < folder->frames().size(); ++i) {
    auto image = folder->load_image(static_cast<int>(i));
    if (!image) return failure(image.error());
    ++images;
    if (data.imager_width_px == 0) {
      data.imager_width_px = image->cols;
      data.imager_height_px = image->rows;
    }
    auto corners = calib::find_chessboard_corners(*image, data.board.cols, data.board.rows);
    if (!corners) continue;
    calib::BoardView view;
    view.name = folder->frames()[i].image_file;
    for (const auto& p : corners->corners_px) view.corners.push_back({p.x, p.y, 1.0, true});
    data.views.push_back(std::move(view));
  }
  if (images == 0) return failure(make_error("no_frames", "the capture folder holds no frames"));
  if (data.views.empty())
    return failure(make_error("no_board", "no " + std::to_string(data.board.cols) + "x" +
                                              std::to_string(data.board.rows) + " chessboard found in any of the " +
                                              std::to_string(images) + " frames"));

  calib::SolveOptions options;
  calib::Solution solution;
  std::vector<calib::ModelEvidence> evidence;
  const std::string model = request.value("model", "auto");
  if (model == "auto") {
    auto selection = calib::select_model(data, options, calib::default_candidate_models());
    if (!selection) return failure(selection.error());
    solution = std::move(selection->chosen);
    evidence = std::move(selection->evidence);
  } else {
    auto name = calib::configured_lensmodel(model, data.imager_width_px, data.imager_height_px, 90);
    if (!name) return failure(name.error());
    options.lensmodel = *name;
    auto solved = calib::solve(data, options);
    if (!solved) return failure(solved.error());
    solution = std::move(*solved);
  }
  const double pixel_um = request.contains("pixel_um") ? request["pixel_um"].get<double>()
                                                       : manifest_pixel_pitch_um(*folder);
  calib::CalibrationReport report = calib::make_report(data, solution, pixel_um);
  report.evidence = std::move(evidence);
  const nlohmann::json report_json = calib::to_json(report);
  const std::string model_text =
      calib::cameramodel_text(solution.model, "camlabd calibration job " + std::to_string(job.id));

  const std::filesystem::path out = data_dir / job.folder;
  std::error_code ec;
  std::filesystem::create_directories(out, ec);
  if (ec) return failure(make_error("io_error", "cannot create " + out.string() + ": " + ec.message()));
  if (auto s = image::write_file_atomically(out / "camera.cameramodel", model_text); !s) return failure(s.error());
  if (auto s = image::write_file_atomically(out / "report.json", report_json.dump(2) + "\n"); !s)
    return failure(s.error());

  JobOutcome outcome;
  outcome.state = JobState::kSucceeded;
  outcome.result = {{"report", report_json},
                    {"cameramodel", model_text},
                    {"cameramodel_file", job.folder + "/camera.cameramodel"},
                    {"views_with_board", static_cast<int>(data.views.size())},
                    {"frames", images}};
  return outcome;
}

JobOutcome execute_analysis(const JobRecord& job, const std::filesystem::path& data_dir) {
  const std::filesystem::path dir = data_dir / job.request.at("source_folder").get<std::string>();
  const std::string kind = job.request.at("analysis").get<std::string>();
  JobOutcome outcome;
  outcome.state = JobState::kSucceeded;
  if (kind == "defocus") {
    analysis::DefocusOptions options;
    options.threads = 1;  // the compute thread; cameras and HTTP keep the other core
    auto report = analysis::analyze_defocus(dir, options);
    if (!report) return failure(report.error());
    outcome.result = {{"report", analysis::to_json(*report)}};
  } else if (kind == "exposure") {
    auto report = analysis::analyze_exposure(dir, analysis::ExposureOptions{});
    if (!report) return failure(report.error());
    outcome.result = {{"report", analysis::to_json(*report)}};
  } else if (kind == "focus") {
    auto report = analysis::analyze_focus(dir, analysis::FocusStackOptions{});
    if (!report) return failure(report.error());
    outcome.result = {{"report", analysis::to_json(*report)}};
  } else {
    return failure(make_error("invalid_request", "unknown analysis '" + kind + "'"));
  }
  return outcome;
}

ComputeWorker::ComputeWorker(std::filesystem::path data_dir, JobStore& store, Metrics& metrics, int max_queued_jobs)
    : data_dir_(std::move(data_dir)), store_(store), metrics_(metrics), max_queued_jobs_(max_queued_jobs) {}

ComputeWorker::~ComputeWorker() { stop(); }

void ComputeWorker::start() { thread_ = std::thread([this] { run(); }); }

void ComputeWorker::stop() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

bool ComputeWorker::can_accept_job() const {
  std::lock_guard lock(mutex_);
  return !stopping_ && static_cast<int>(jobs_.size()) < max_queued_jobs_;
}

Status ComputeWorker::enqueue_job(int64_t id) {
  {
    std::lock_guard lock(mutex_);
    if (stopping_) return make_error("shutting_down", "camlabd is shutting down");
    if (static_cast<int>(jobs_.size()) >= max_queued_jobs_)
      return make_error("too_many_jobs", "the compute queue is full (" + std::to_string(max_queued_jobs_) +
                                             " jobs); retry later");
    jobs_.push_back(id);
  }
  wake_.notify_all();
  return {};
}

void ComputeWorker::run() {
  for (;;) {
    int64_t id = 0;
    {
      std::unique_lock lock(mutex_);
      wake_.wait(lock, [this] { return stopping_ || !jobs_.empty(); });
      if (stopping_) break;
      id = jobs_.front();
      jobs_.pop_front();
    }
    auto record = store_.get(id);
    if (!record || !record->has_value()) continue;
    auto started = store_.start(id);
    if (!started || !*started) continue;
    const JobRecord& job = **record;
    log_info("job %lld (%s) started", static_cast<long long>(id), job.kind.c_str());
    JobOutcome outcome;
    // The libraries return errors as values; an exception here is a bug in a library or
    // a request the handler let through malformed, and must not take the daemon down.
    try {
      outcome = job.kind == "calibration" ? execute_calibration(job, data_dir_) : execute_analysis(job, data_dir_);
    } catch (const std::exception& e) {
      outcome = failure(make_error("internal", std::string("the job failed unexpectedly: ") + e.what()));
    }
    (void)store_.finish(id, outcome.state, outcome.error, outcome.result);
    metrics_.count_job_finished(job.kind, job_state_name(outcome.state));
    log_info("job %lld %s%s%s", static_cast<long long>(id), job_state_name(outcome.state), outcome.error ? ": " : "",
             outcome.error ? outcome.error->message.c_str() : "");
  }
  std::deque<int64_t> left;
  {
    std::lock_guard lock(mutex_);
    left.swap(jobs_);
  }
  for (int64_t id : left)
    (void)store_.finish(id, JobState::kInterrupted,
                        make_error("interrupted", "camlabd stopped before the job started"), nullptr);
}

}  // namespace camlab::service
