#include "service/jobs/calibration_sessions.h"

#include "base/log.h"
#include "image/capture_folder.h"
#include "image/frame_views.h"
#include "service/jobs/calibration_request.h"
#include "service/jobs/calibration_session.h"
#include "service/jobs/camera_set.h"
#include "service/jobs/compute_jobs.h"
#include "service/store/job_store.h"

namespace camlab::service {

// A session the daemon holds open. `session` is worked on by the manager's thread only;
// the rest is guarded by the manager's mutex.
struct CalibrationSessions::Live {
  int64_t id = 0;
  std::string camera_id;
  nlohmann::json request;
  std::string folder;  // relative to the data folder
  std::unique_ptr<CalibrationSession> session;
  nlohmann::json published = nlohmann::json::object();  // session->to_json() of the last step
  // "ready" (waiting for the next view), "capturing", "solving", "finishing".
  std::string phase = "ready";
  int64_t capture_job = 0;  // the view's capture while capturing
  double pixel_pitch_um = 0;
  bool cancelled = false;
};

CalibrationSessions::CalibrationSessions(std::filesystem::path data_dir, JobStore& store,
                                         CameraSet& cameras, int max_live_sessions,
                                         std::chrono::milliseconds capture_timeout)
    : data_dir_(std::move(data_dir)),
      store_(store),
      cameras_(cameras),
      max_live_sessions_(max_live_sessions),
      capture_timeout_(capture_timeout) {}

CalibrationSessions::~CalibrationSessions() { stop(); }

void CalibrationSessions::start() {
  thread_ = std::thread([this] { run(); });
}

void CalibrationSessions::stop() {
  {
    std::lock_guard lock(mutex_);
    if (stopping_ && !thread_.joinable()) return;
    stopping_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
  std::lock_guard lock(mutex_);
  for (const auto& [id, live] : live_)
    (void)store_.finish(id, JobState::kInterrupted,
                        make_error("interrupted", "camlabd stopped during the session"),
                        state_json(*live));
  live_.clear();
}

std::shared_ptr<CalibrationSessions::Live> CalibrationSessions::find_live(int64_t id) {
  auto it = live_.find(id);
  return it == live_.end() ? nullptr : it->second;
}

nlohmann::json CalibrationSessions::state_json(const Live& live) const {
  nlohmann::json json = live.published;
  json["id"] = live.id;
  json["camera_id"] = live.camera_id;
  json["state"] = "running";
  json["phase"] = live.phase;
  json["request"] = live.request;
  json["folder"] = live.folder;
  json["capture_job"] = live.capture_job > 0 ? nlohmann::json(live.capture_job) : nullptr;
  return json;
}

Result<nlohmann::json> CalibrationSessions::open(const std::string& camera_id,
                                                 const nlohmann::json& request) {
  auto worker = cameras_.find(camera_id);
  if (!worker) return make_error("not_found", "no camera '" + camera_id.substr(0, 100) + "'");
  const CameraSnapshot snapshot = worker->snapshot();
  if (!snapshot.available)
    return make_error("no_device",
                      "camera " + camera_id + " is not available: " + snapshot.unavailable_reason);
  std::lock_guard lock(mutex_);
  if (stopping_) return make_error("shutting_down", "camlabd is stopping");
  if (static_cast<int>(live_.size()) >= max_live_sessions_)
    return make_error("too_many_jobs", std::to_string(max_live_sessions_) +
                                           " calibration sessions are open; finish or cancel one");
  JobRecord record;
  CAMLAB_ASSIGN(
      record, store_.create("calibration_session", camera_id, request, "calibrations/session-", 0));
  if (auto started = store_.start(record.id); !started || !*started)
    return make_error("internal", "cannot start the session's job record");
  auto live = std::make_shared<Live>();
  live->id = record.id;
  live->camera_id = camera_id;
  live->request = request;
  live->folder = record.folder;
  live->session = std::make_unique<CalibrationSession>(calibration_options(request),
                                                       request.value("target_uncertainty_px", 0.5));
  live->published = live->session->to_json();
  live->pixel_pitch_um = request.value("pixel_um", 0.0);
  live_[record.id] = live;
  log_info(log::Category::kJobs, "calibration session %lld opened on %s",
           static_cast<long long>(record.id), camera_id.c_str());
  return state_json(*live);
}

Error CalibrationSessions::not_live(int64_t id) {
  auto record = store_.get(id);
  if (record && record->has_value() && (*record)->kind == "calibration_session")
    return make_error("conflict", "calibration session " + std::to_string(id) + " has ended (" +
                                      job_state_name((*record)->state) + ")");
  return make_error("not_found", "no calibration session " + std::to_string(id));
}

Result<nlohmann::json> CalibrationSessions::state(int64_t id) {
  {
    std::lock_guard lock(mutex_);
    if (auto live = find_live(id)) return state_json(*live);
  }
  std::optional<JobRecord> record;
  CAMLAB_ASSIGN(record, store_.get(id));
  if (!record || record->kind != "calibration_session")
    return make_error("not_found", "no calibration session " + std::to_string(id));
  // Ended: the record has the last state (and, when finished, the report).
  nlohmann::json json = record->result.is_object()
                            ? record->result.value("session", nlohmann::json::object())
                            : nlohmann::json::object();
  json["id"] = id;
  json["camera_id"] = record->camera_id;
  json["state"] = job_state_name(record->state);
  json["phase"] = "ended";
  json["request"] = record->request;
  json["folder"] = record->folder;
  if (record->result.is_object() && record->result.contains("report"))
    json["report"] = record->result["report"];
  if (!record->error_code.empty())
    json["error"] = {{"code", record->error_code}, {"message", record->error_message}};
  return json;
}

Result<nlohmann::json> CalibrationSessions::take_view(int64_t id) {
  std::shared_ptr<Live> live;
  {
    std::lock_guard lock(mutex_);
    live = find_live(id);
    if (!live) return not_live(id);  // reads the store only: safe under the mutex
    if (live->phase != "ready")
      return make_error("conflict", "session " + std::to_string(id) + " is " + live->phase +
                                        "; wait until its phase is \"ready\"");
    if (stopping_) return make_error("shutting_down", "camlabd is stopping");
  }
  auto worker = cameras_.find(live->camera_id);
  if (!worker) return make_error("no_device", "camera " + live->camera_id + " is gone");
  if (Status accepted = worker->can_accept_job(); !accepted) return accepted.error();
  const int views = live->published.value("frames", nlohmann::json::array()).size();
  const nlohmann::json capture = {
      {"kind", "single"},
      {"label", "calibration session " + std::to_string(id) + " view " + std::to_string(views)}};
  JobRecord job;
  CAMLAB_ASSIGN(job, store_.create("capture", worker->id(), capture, "captures/job-", 1));
  if (auto s = worker->enqueue_job(job.id); !s) {
    (void)store_.finish(job.id, JobState::kCancelled, s.error(), nullptr);
    return s.error();
  }
  std::lock_guard lock(mutex_);
  live->phase = "capturing";
  live->capture_job = job.id;
  pending_.push_back({id, Work::kView, job.id});
  wake_.notify_all();
  return state_json(*live);
}

Result<nlohmann::json> CalibrationSessions::finish(int64_t id) {
  std::lock_guard lock(mutex_);
  auto live = find_live(id);
  if (!live) return not_live(id);  // reads the store only: safe under the mutex
  if (live->phase != "ready")
    return make_error("conflict", "session " + std::to_string(id) + " is " + live->phase +
                                      "; wait until its phase is \"ready\"");
  const int views = live->published.value("views_with_board", 0);
  if (views < 2)
    return make_error("too_few_views", "the session has " + std::to_string(views) +
                                           " view(s) with a board; a calibration needs 2 or "
                                           "more (take more views first)");
  live->phase = "finishing";
  pending_.push_back({id, Work::kFinish, 0});
  wake_.notify_all();
  return state_json(*live);
}

Result<nlohmann::json> CalibrationSessions::cancel(int64_t id) {
  std::lock_guard lock(mutex_);
  auto live = find_live(id);
  if (!live) return not_live(id);  // reads the store only: safe under the mutex
  // The session thread may hold the session (a view in progress): it sees `cancelled`
  // and drops it; the record ends now.
  live->cancelled = true;
  nlohmann::json json = state_json(*live);
  live_.erase(id);
  (void)store_.finish(id, JobState::kCancelled,
                      make_error("cancelled", "the session was cancelled"), {{"session", json}});
  json["state"] = "cancelled";
  json["phase"] = "ended";
  return json;
}

void CalibrationSessions::run() {
  for (;;) {
    Pending work;
    std::shared_ptr<Live> live;
    {
      std::unique_lock lock(mutex_);
      wake_.wait(lock, [this] { return stopping_ || !pending_.empty(); });
      if (stopping_) return;
      work = pending_.front();
      pending_.pop_front();
      live = find_live(work.session);
      if (!live) continue;  // cancelled meanwhile
    }
    // Library errors are values; an exception is a bug that must not take camlabd down.
    try {
      if (work.work == Work::kView)
        do_view(live, work.capture_job);
      else
        do_finish(live);
    } catch (const std::exception& e) {
      log_error(log::Category::kJobs, "calibration session %lld: %s",
                static_cast<long long>(work.session), e.what());
      std::lock_guard lock(mutex_);
      live->phase = "ready";
      live->published["last_error"] = {{"code", "internal"}, {"message", e.what()}};
    }
  }
}

void CalibrationSessions::do_view(const std::shared_ptr<Live>& live, int64_t capture_job) {
  // Wait for the capture (bounded; stop() and cancel() end the wait).
  const auto deadline = std::chrono::steady_clock::now() + capture_timeout_;
  std::optional<JobRecord> capture;
  for (;;) {
    auto record = store_.get(capture_job);
    if (record && record->has_value() && is_finished((*record)->state)) {
      capture = **record;
      break;
    }
    std::unique_lock lock(mutex_);
    if (stopping_ || live->cancelled) return;
    if (std::chrono::steady_clock::now() > deadline) break;
    wake_.wait_for(lock, std::chrono::milliseconds(20));
  }
  auto publish_error = [&](const Error& error) {
    live->session->note_error(error);
    std::lock_guard lock(mutex_);
    live->published = live->session->to_json();
    live->phase = "ready";
    live->capture_job = 0;
  };
  if (!capture)
    return publish_error(make_error(
        "timeout", "capture job " + std::to_string(capture_job) + " did not finish within " +
                       std::to_string(capture_timeout_.count()) + " ms"));
  if (capture->state != JobState::kSucceeded)
    // The capture's own code (device_lost, timeout, ...) says what went wrong.
    return publish_error(Error(
        find_error_code(capture->error_code).value_or(ErrorCode::kCancelled),
        "capture job " + std::to_string(capture_job) + " ended " + job_state_name(capture->state) +
            (capture->error_message.empty() ? "" : ": " + capture->error_message)));
  {
    std::lock_guard lock(mutex_);
    live->phase = "solving";
  }
  auto folder = image::CaptureFolder::open(data_dir_ / capture->folder);
  if (!folder) return publish_error(folder.error());
  if (folder->frames().empty())
    return publish_error(
        make_error("no_frames", "capture job " + std::to_string(capture_job) + " stored no frame"));
  auto stored = folder->load_stored_image(0);
  if (!stored) return publish_error(stored.error());
  auto sidecar = folder->load_sidecar(0);
  if (!sidecar) return publish_error(sidecar.error());
  auto luminance = image::luminance_view(*stored, *sidecar);
  if (!luminance) return publish_error(luminance.error());
  if (live->pixel_pitch_um <= 0) live->pixel_pitch_um = image::manifest_pixel_pitch_um(*folder);
  const std::string frame = capture->folder + "/" + folder->frames()[0].image_file;
  if (Status s = live->session->add_frame(*luminance, capture_job, frame); !s)
    return publish_error(s.error());
  nlohmann::json published = live->session->to_json();
  std::lock_guard lock(mutex_);
  live->published = std::move(published);
  live->phase = "ready";
  live->capture_job = 0;
  (void)store_.progress(live->id, live->session->views_found(), 0, 0);
}

void CalibrationSessions::do_finish(const std::shared_ptr<Live>& live) {
  const double pitch =
      live->pixel_pitch_um > 0 && live->pixel_pitch_um <= 100 ? live->pixel_pitch_um : 0;
  auto report = live->session->finish(data_dir_ / live->folder, pitch);
  std::lock_guard lock(mutex_);
  if (live->cancelled) return;
  nlohmann::json session = state_json(*live);
  session.erase("request");
  if (report) {
    (void)store_.finish(live->id, JobState::kSucceeded, std::nullopt,
                        {{"report", *report}, {"session", session}});
    log_info(log::Category::kJobs, "calibration session %lld finished",
             static_cast<long long>(live->id));
  } else {
    (void)store_.finish(live->id, JobState::kFailed, report.error(), {{"session", session}});
  }
  live_.erase(live->id);
}

}  // namespace camlab::service
