#include "service/jobs/compute_jobs.h"

#include <opencv2/core.hpp>

#include "analysis/analyze_folder.h"
#include "base/atomic_file.h"
#include "base/log.h"
#include "calib/calibrate.h"
#include "calib/calibration_request.h"
#include "calib/model_io.h"
#include "calib/rig/rig_calibrate.h"
#include "image/capture_folder.h"
#include "service/jobs/calibration_request.h"
#include "service/metrics.h"

namespace camlab::service {

namespace {

JobOutcome failure(Error error) {
  JobOutcome outcome;
  outcome.state = JobState::kFailed;
  outcome.error = std::move(error);
  return outcome;
}

}  // namespace

namespace {

// A rig calibration (request "rig_sources"): the same run as `camlab calibrate --rig --job
// ...` (calib/rig/rig_calibrate.h), camera-N.cameramodel and rig.json in the job's folder.
JobOutcome execute_rig_calibration(const JobRecord& job, const std::filesystem::path& data_dir,
                                   const std::atomic<bool>* cancel) {
  const nlohmann::json& request = job.request;
  calib::RigCalibrateOptions rig;
  rig.model = request.value("model", std::string("auto"));
  rig.cancel = cancel;
  for (const auto& source : request.at("rig_sources")) {
    calib::CalibrateOptions options = calibration_options(request);
    options.job_dir = data_dir / source.at("source_folder").get<std::string>();
    options.detect_threads = 1;  // the compute thread's one core
    rig.cameras.push_back(std::move(options));
  }
  // A rig capture: its rig views pair the frames (frame file -> view, per camera).
  if (request.contains("rig_view_frames"))
    for (const auto& frames : request["rig_view_frames"])
      rig.view_of_frame.push_back(frames.get<std::map<std::string, std::string>>());
  rig.out_dir = data_dir / job.folder;
  auto run = calib::calibrate_rig(rig);
  if (!run) return failure(run.error());
  JobOutcome outcome;
  outcome.state = JobState::kSucceeded;
  outcome.result = {{"report", run->report}, {"rig", true}};
  if (request.contains("rig_views_left_out"))
    outcome.result["rig_views_left_out"] = request["rig_views_left_out"];
  nlohmann::json files = nlohmann::json::array();
  for (size_t c = 0; c < rig.cameras.size(); ++c)
    files.push_back(job.folder + "/camera-" + std::to_string(c) + ".cameramodel");
  outcome.result["cameramodel_files"] = files;
  return outcome;
}

}  // namespace

JobOutcome execute_calibration(const JobRecord& job, const std::filesystem::path& data_dir,
                               const std::atomic<bool>* cancel) {
  const nlohmann::json& request = job.request;
  if (request.contains("rig_sources")) return execute_rig_calibration(job, data_dir, cancel);
  const std::filesystem::path source = data_dir / request.at("source_folder").get<std::string>();
  auto folder = image::CaptureFolder::open(source);
  if (!folder) return failure(folder.error());
  if (folder->frames().empty())
    return failure(make_error("no_frames", "the capture folder holds no frames"));

  // The same run as `camlab calibrate --job` (calib/calibrate.h): detector choice, corner
  // weights, model selection, report, and a model file with mrcal's optimization inputs.
  calib::CalibrateOptions options = calibration_options(request);
  options.job_dir = source;
  const double pixel_um = request.contains("pixel_um") ? request["pixel_um"].get<double>()
                                                       : image::manifest_pixel_pitch_um(*folder);
  options.pixel_pitch_um =
      pixel_um >= calib::kPixelPitchMinUm && pixel_um <= calib::kPixelPitchMaxUm ? pixel_um : 0;
  options.cancel = cancel;
  options.detect_threads = 1;  // the compute thread's one core; the others serve cameras and HTTP
  const std::filesystem::path out = data_dir / job.folder;
  std::error_code ec;
  std::filesystem::create_directories(out, ec);
  if (ec)
    return failure(make_error("io_error", "cannot create " + out.string() + ": " + ec.message()));
  options.out_cameramodel = out / "camera.cameramodel";
  options.out_report_json = out / "report.json";
  options.plots_dir = out / "plots";  // GET /v1/jobs/{id}/plots

  auto run = calib::calibrate(options);
  if (!run) return failure(run.error());
  auto report = calib::write_calibration_outputs(&*run, options);
  if (!report) return failure(report.error());

  JobOutcome outcome;
  outcome.state = JobState::kSucceeded;
  // The result's model text is the bare model (a few hundred bytes); the file carries
  // the optimization inputs too (about 100 kB for 40 views).
  outcome.result = {
      {"report", *report},
      {"cameramodel", calib::cameramodel_text(run->report.solution.model,
                                              "camlabd calibration job " + std::to_string(job.id))},
      {"cameramodel_file", job.folder + "/camera.cameramodel"},
      {"views_with_board", static_cast<int>(run->data.views.size())},
      {"frames", run->images}};
  return outcome;
}

JobOutcome execute_analysis(const JobRecord& job, const std::filesystem::path& data_dir,
                            const std::atomic<bool>* cancel) {
  const std::filesystem::path dir = data_dir / job.request.at("source_folder").get<std::string>();
  const std::string kind = job.request.at("analysis").get<std::string>();
  // The same run as `camlab analyze KIND DIR --plots` (analysis/analyze_folder.h): the
  // report, its warnings, and the plots in the job's folder (GET /v1/jobs/{id}/plots).
  analysis::AnalyzeOptions options;
  options.defocus.threads = 1;  // the compute thread; cameras and HTTP keep the other core
  options.cancel = cancel;
  if (!job.folder.empty()) options.plots_dir = data_dir / job.folder / "plots";
  auto run = analysis::analyze(kind, dir, options);
  std::optional<Error> plots_failed;
  if (!run && !options.plots_dir.empty() &&
      (run.error().code == ErrorCode::kEmptyPlot ||
       run.error().code == ErrorCode::kPlotterFailed)) {
    // A measurement with nothing to draw, or no gnuplot to draw it, still has its numbers.
    plots_failed = run.error();
    options.plots_dir.clear();
    run = analysis::analyze(kind, dir, options);
  }
  if (!run) return failure(run.error());
  JobOutcome outcome;
  outcome.state = JobState::kSucceeded;
  outcome.result = {{"report", run->report}};
  if (plots_failed) outcome.result["plots_skipped"] = plots_failed->message;
  return outcome;
}

ComputeWorker::ComputeWorker(std::filesystem::path data_dir, JobStore& store, Metrics& metrics,
                             int max_queued_jobs)
    : data_dir_(std::move(data_dir)),
      store_(store),
      metrics_(metrics),
      max_queued_jobs_(max_queued_jobs) {}

ComputeWorker::~ComputeWorker() { stop(); }

void ComputeWorker::start() {
  thread_ = std::thread([this] { run(); });
}

void ComputeWorker::stop() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  cancel_ = true;
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void ComputeWorker::wait_for_store(int64_t id, const Error& why) {
  log_warning(log::Category::kJobs, "job %lld: %s; trying again in 1 s", static_cast<long long>(id),
              why.message.c_str());
  std::unique_lock lock(mutex_);
  wake_.wait_for(lock, std::chrono::seconds(1), [this] { return stopping_; });
  jobs_.push_back(id);  // a stop ends it interrupted with the rest
}

bool ComputeWorker::cancel_running(int64_t id) {
  if (id == 0 || running_job_.load() != id) return false;
  cancel_ = true;
  return true;
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
      return make_error(
          "too_many_jobs",
          "the compute queue is full (" + std::to_string(max_queued_jobs_) + " jobs); retry later");
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
    if (!record) {
      // The database away (a fleet's PostgreSQL restarting): the job is still queued in
      // it and would wait there for ever once dropped here, so it waits in this queue.
      wait_for_store(id, record.error());
      continue;
    }
    if (!record->has_value()) continue;
    {
      std::lock_guard lock(mutex_);
      if (!stopping_) cancel_ = false;
    }
    // Cancellable before the store says running: a DELETE that reads "running" must find
    // the job here (it answered 409 not_cancellable in that window), and one that still
    // reads "queued" cancels it in the store, so that start() refuses it.
    running_job_ = id;
    auto started = store_.start(id);
    if (!started || !*started) {
      running_job_ = 0;
      if (!started) wait_for_store(id, started.error());  // false: cancelled while queued
      continue;
    }
    const JobRecord& job = **record;
    log_info(log::Category::kJobs, "job %lld (%s) started", static_cast<long long>(id),
             job.kind.c_str());
    JobOutcome outcome;
    // The libraries return errors as values; an exception here is a bug in a library or
    // a request the handler let through malformed, and must not take the daemon down.
    try {
      outcome = job.kind == "calibration" ? execute_calibration(job, data_dir_, &cancel_)
                                          : execute_analysis(job, data_dir_, &cancel_);
    } catch (const std::exception& e) {
      outcome =
          failure(make_error("internal", std::string("the job failed unexpectedly: ") + e.what()));
    }
    running_job_ = 0;
    if (outcome.error && outcome.error->code == ErrorCode::kCancelled) {
      std::lock_guard lock(mutex_);
      // Stopped by camlabd's shutdown it is interrupted (as a capture is), by DELETE cancelled.
      outcome.state = stopping_ ? JobState::kInterrupted : JobState::kCancelled;
      if (stopping_) outcome.error = make_error("interrupted", "camlabd stopped while it ran");
    }
    (void)store_.finish(id, outcome.state, outcome.error, outcome.result);
    log_info(log::Category::kJobs, "job %lld %s%s%s", static_cast<long long>(id),
             job_state_name(outcome.state), outcome.error ? ": " : "",
             outcome.error ? outcome.error->message.c_str() : "");
  }
  std::deque<int64_t> left;
  {
    std::lock_guard lock(mutex_);
    left.swap(jobs_);
  }
  for (int64_t id : left)
    (void)store_.finish(id, JobState::kInterrupted,
                        make_error("interrupted", "camlabd stopped before the job started"),
                        nullptr);
}

}  // namespace camlab::service
