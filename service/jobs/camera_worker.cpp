#include "service/jobs/camera_worker.h"

#include "base/log.h"
#include "device/camera_json.h"
#include "service/jobs/capture_job.h"
#include "service/jobs/live_preview.h"
#include "service/metrics.h"
#include "service/store/job_store.h"

namespace camlab::service {

CameraWorker::CameraWorker(device::DeviceEntry entry, OpenCamera open, CameraWorkerOptions options,
                           JobStore& store, Metrics& metrics)
    : entry_(std::move(entry)),
      open_(std::move(open)),
      options_(std::move(options)),
      store_(store),
      metrics_(metrics),
      live_(std::make_shared<LiveFeed>(entry_.identity.id, options_.traits)) {
  // Someone started watching: wake the worker to preview (under the lock, so that the
  // wake-up cannot fall between its check and its wait).
  live_->set_demand_listener([this] {
    { std::lock_guard lock(mutex_); }
    wake_.notify_all();
  });
  snapshot_.identity = entry_.identity;
  snapshot_.transport = entry_.transport;
  snapshot_.also_reachable_as = entry_.also_reachable_as;
  snapshot_.traits = options_.traits;
  snapshot_.unavailable_reason = "not opened yet";
  snapshot_.description = device::to_json(entry_.identity);
}

CameraWorker::~CameraWorker() { stop(); }

void CameraWorker::start() {
  thread_ = std::thread([this] { run(); });
  std::unique_lock lock(mutex_);
  // Opening a V4L2 device takes milliseconds; a wedged one must not hold up the daemon.
  wake_.wait_for(lock, std::chrono::seconds(10), [this] { return started_snapshot_; });
}

void CameraWorker::request_stop() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
    shutting_down_ = true;
    cancel_ = true;
  }
  wake_.notify_all();
}

void CameraWorker::stop() {
  request_stop();
  join();
}

void CameraWorker::join() {
  if (thread_.joinable()) thread_.join();
}

void CameraWorker::retire(const std::string& reason) {
  {
    std::lock_guard lock(mutex_);
    if (lost_) return;
    lost_reason_ = reason;
    lost_ = true;
    stopping_ = true;
    cancel_ = true;
    snapshot_.gone = true;
    snapshot_.gone_since_ms = unix_time_ms();
    snapshot_.available = false;
    snapshot_.unavailable_reason = reason;
  }
  live_->close();
  wake_.notify_all();
}

bool CameraWorker::retired() const { return lost_.load(); }

void CameraWorker::reopen_if_unavailable() {
  {
    std::lock_guard lock(mutex_);
    if (stopping_ || snapshot_.available || !started_snapshot_ || !tasks_.empty()) return;
    tasks_.push_back([](device::Camera*, const Error*) {});  // the worker opens it first
  }
  wake_.notify_all();
}

CameraSnapshot CameraWorker::snapshot() const {
  std::lock_guard lock(mutex_);
  CameraSnapshot copy = snapshot_;
  copy.running_job = running_job_.load();
  copy.queued_jobs = static_cast<int>(jobs_.size());
  return copy;
}

Status CameraWorker::post_task(Task task) {
  {
    std::lock_guard lock(mutex_);
    if (lost_) return make_error("no_device", "camera " + id() + " is gone (" + lost_reason_ + ")");
    if (stopping_) return make_error("shutting_down", "camlabd is shutting down");
    tasks_.push_back(std::move(task));
  }
  wake_.notify_all();
  return {};
}

Status CameraWorker::post_task(Task task, std::function<void()> then) {
  return post_task([this, task = std::move(task), then = std::move(then)](
                       device::Camera* camera, const Error* unavailable) {
    task(camera, unavailable);
    if (camera) refresh_snapshot();
    then();
  });
}

Status CameraWorker::can_accept_job() const {
  std::lock_guard lock(mutex_);
  if (lost_)
    return make_error("no_device", "camera " + id() + " is gone (" + lost_reason_ +
                                       "); it is served again when it is plugged in");
  if (stopping_) return make_error("shutting_down", "camlabd is shutting down");
  if (static_cast<int>(jobs_.size()) >= options_.max_queued_jobs)
    return make_error("too_many_jobs", "camera " + id() + " has too many jobs queued; retry later");
  return {};
}

Result<JobRecord> CameraWorker::store_and_enqueue(JobStore& store, const std::string& kind,
                                                  const nlohmann::json& request, int frames_total) {
  if (Status accepted = can_accept_job(); !accepted) return accepted.error();
  auto job =
      store.create(kind, id(), request, kind == "capture" ? "captures/job-" : "", frames_total);
  if (!job) return job.error();
  if (Status queued = enqueue_job(job->id); !queued) {
    (void)store.finish(job->id, JobState::kCancelled, queued.error(), nullptr);
    return queued.error();
  }
  return job;
}

Status CameraWorker::enqueue_job(int64_t job_id) {
  {
    std::lock_guard lock(mutex_);
    if (lost_)
      return make_error("no_device", "camera " + id() + " is gone (" + lost_reason_ +
                                         "); it is served again when it is plugged in");
    if (stopping_) return make_error("shutting_down", "camlabd is shutting down");
    if (static_cast<int>(jobs_.size()) >= options_.max_queued_jobs)
      return make_error("too_many_jobs", "camera " + id() + " already has " +
                                             std::to_string(jobs_.size()) + " jobs queued (limit " +
                                             std::to_string(options_.max_queued_jobs) +
                                             "); retry later");
    jobs_.push_back(job_id);
  }
  wake_.notify_all();
  return {};
}

void CameraWorker::forget_queued(int64_t id) {
  std::lock_guard lock(mutex_);
  std::erase(jobs_, id);
}

bool CameraWorker::cancel_running(int64_t id) {
  if (id == 0 || running_job_.load() != id) return false;
  cancel_ = true;
  return true;
}

Result<device::Camera*> CameraWorker::ensure_open() {
  if (camera_) return camera_.get();
  auto camera = open_();
  if (!camera) {
    std::lock_guard lock(mutex_);
    snapshot_.available = false;
    snapshot_.unavailable_reason = camera.error().message;
    return camera.error();
  }
  camera_ = std::move(*camera);
  refresh_snapshot();
  return camera_.get();
}

void CameraWorker::drop_camera(const Error& why) {
  camera_.reset();
  std::lock_guard lock(mutex_);
  snapshot_.available = false;
  snapshot_.unavailable_reason = why.message;
}

void CameraWorker::refresh_snapshot() {
  if (!camera_) return;
  nlohmann::json description = device::describe_camera(*camera_);
  auto controls = camera_->controls();
  auto formats = camera_->formats();
  std::lock_guard lock(mutex_);
  snapshot_.description = std::move(description);
  snapshot_.available = controls.ok() && formats.ok();
  snapshot_.unavailable_reason =
      snapshot_.available ? "" : (!controls ? controls.error() : formats.error()).message;
  if (controls) snapshot_.controls = std::move(*controls);
  if (formats) snapshot_.formats = std::move(*formats);
}

CaptureJobEnv CameraWorker::job_env() {
  CaptureJobEnv env{
      store_,          metrics_,         options_.data_dir,      options_.spec_latency_frames,
      options_.traits, nlohmann::json(), options_.frame_timeout, &cancel_,
      &shutting_down_, live_.get()};
  env.source = snapshot().description;
  env.previous_work = previous_work_;
  env.previous_work_ended_unix_ms = previous_work_ended_unix_ms_;
  env.source["transport"] = entry_.transport;
  for (const auto& [key, value] : options_.source_extra.items()) env.source[key] = value;
  return env;
}

void CameraWorker::probe_latency_at_startup(device::Camera& camera) {
  auto stored = store_.latency(id());
  if (!stored || stored->has_value()) return;
  {
    std::lock_guard lock(mutex_);
    if (stopping_) return;
    snapshot_.measuring_latency = true;
  }
  log_info(log::Category::kCameras,
           "camera %s: measuring its control latency (once; kept in the database)", id().c_str());
  int frames = 0;
  Status probed = probe_and_store_latency(camera, job_env(), &frames);
  if (!probed)
    log_warning(log::Category::kCameras,
                "camera %s: start-up latency probe: %s (the first capture probes again)",
                id().c_str(), probed.error().message.c_str());
  {
    std::lock_guard lock(mutex_);
    snapshot_.measuring_latency = false;
  }
  previous_work_ = "measuring its control latency at start-up (" + std::to_string(frames) +
                   " frames, once per camera)";
  previous_work_ended_unix_ms_ = unix_time_ms();
  if (!probed && is_device_error(probed.error().code)) drop_camera(probed.error());
  refresh_snapshot();
}

void CameraWorker::run() {
  auto opened = ensure_open();
  if (!opened)
    log_warning(log::Category::kCameras, "camera %s: cannot open: %s", id().c_str(),
                opened.error().message.c_str());
  {
    std::lock_guard lock(mutex_);
    started_snapshot_ = true;
  }
  wake_.notify_all();
  if (opened) probe_latency_at_startup(**opened);

  for (;;) {
    Task task;
    int64_t job = 0;
    {
      std::unique_lock lock(mutex_);
      wake_.wait(lock, [this] {
        return stopping_ || !tasks_.empty() || !jobs_.empty() || live_->wanted();
      });
      if (stopping_) break;
      if (!tasks_.empty()) {
        task = std::move(tasks_.front());
        tasks_.pop_front();
      } else if (!jobs_.empty()) {
        job = jobs_.front();
        jobs_.pop_front();
      }
    }
    if (task) {
      auto camera = ensure_open();
      task(camera ? *camera : nullptr, camera ? nullptr : &camera.error());
      refresh_snapshot();
    } else if (job != 0) {
      run_job(job);
    } else {
      run_preview();
    }
  }
  live_->close();

  // Shutting down: answer the tasks still waiting, and leave no job queued.
  std::deque<Task> tasks;
  std::deque<int64_t> jobs;
  {
    std::lock_guard lock(mutex_);
    tasks.swap(tasks_);
    jobs.swap(jobs_);
  }
  const Error stopping = lost_ ? make_error("no_device", "camera " + id() + " is gone")
                               : make_error("shutting_down", "camlabd is shutting down");
  for (auto& task : tasks) task(nullptr, &stopping);
  for (int64_t id : jobs) end_unstarted(id);
  camera_.reset();  // stops streaming and closes the device on its own thread
  finished_ = true;
}

void CameraWorker::run_queued_tasks() {
  for (;;) {
    Task task;
    {
      std::lock_guard lock(mutex_);
      if (tasks_.empty() || stopping_) return;
      task = std::move(tasks_.front());
      tasks_.pop_front();
    }
    auto camera = ensure_open();
    task(camera ? *camera : nullptr, camera ? nullptr : &camera.error());
    refresh_snapshot();
  }
}

void CameraWorker::run_preview() {
  auto camera = ensure_open();
  Status previewed = camera ? Status{} : Status(camera.error());
  if (camera) {
    const CameraSnapshot now = snapshot();
    auto format = preview_format(now.controls, now.formats, options_.traits);
    if (!format) {
      previewed = format.error();
    } else {
      previewed = run_live_preview(
          **camera, *format, *live_,
          [this] {
            std::lock_guard lock(mutex_);
            return !stopping_ && jobs_.empty() && live_->wanted();
          },
          [this] { run_queued_tasks(); }, options_.frame_timeout);
    }
  }
  if (previewed.ok()) return;
  // Logged once per preview; the viewers keep their last frame. A camera that failed is
  // reopened on the next try, after a pause that keeps a broken one from spinning.
  log_warning(log::Category::kCameras, "camera %s: live preview stopped: %s", id().c_str(),
              previewed.error().message.c_str());
  if (camera && is_device_error(previewed.error().code)) drop_camera(previewed.error());
  std::unique_lock lock(mutex_);
  wake_.wait_for(lock, std::chrono::seconds(1),
                 [this] { return stopping_ || !tasks_.empty() || !jobs_.empty(); });
}

void CameraWorker::end_unstarted(int64_t job_id) {
  std::string reason;
  {
    std::lock_guard lock(mutex_);
    reason = lost_reason_;
  }
  const JobState state = lost_ ? JobState::kDeviceLost : JobState::kInterrupted;
  const Error why = lost_ ? make_error("device_lost", "camera " + id() +
                                                          " was unplugged before "
                                                          "the job started (" +
                                                          reason + ")")
                          : make_error("interrupted", "camlabd stopped before the job started");
  (void)store_.finish(job_id, state, why, nullptr);  // counted by the store's observer
}

void CameraWorker::mark_device_lost(JobOutcome* outcome) const {
  std::string reason;
  {
    std::lock_guard lock(mutex_);
    reason = lost_reason_;
  }
  if (reason.empty()) reason = outcome->failure_detail;
  if (reason.empty() && outcome->error) reason = outcome->error->message;
  if (reason.empty()) reason = "the camera is gone";
  int frames = 0;
  if (outcome->result.is_object() && outcome->result.contains("frames_kept"))
    frames = outcome->result["frames_kept"].get<int>();
  outcome->state = JobState::kDeviceLost;
  outcome->device_failed = true;
  outcome->error =
      outcome->result.is_object()
          ? make_error("device_lost", "camera " + id() + " was unplugged during the job (" +
                                          reason + "); the " + std::to_string(frames) +
                                          " frames captured before are kept")
          : make_error(
                "device_lost",
                "camera " + id() + " was unplugged before the job took a frame (" + reason + ")");
  if (outcome->result.is_object()) outcome->result["device_lost_reason"] = reason;
}

void CameraWorker::run_job(int64_t id) {
  auto record = store_.get(id);
  if (!record || !record->has_value()) {
    log_error(log::Category::kJobs, "job %lld: %s", static_cast<long long>(id),
              record ? "vanished from the database" : record.error().message.c_str());
    return;
  }
  const JobRecord& job = **record;
  // Cancellable before the store says running (as the compute worker): a DELETE that reads
  // "running" finds the job here; one that reads "queued" cancels it in the store instead.
  cancel_ = lost_.load();  // a retirement since the job left the queue still cancels it
  running_job_ = id;
  auto started = store_.start(id);
  if (!started || !*started) {  // cancelled while queued
    running_job_ = 0;
    return;
  }
  log_info(log::Category::kJobs, "job %lld (%s) started on camera %s", static_cast<long long>(id),
           job.kind.c_str(), this->id().c_str());

  JobOutcome outcome;
  auto camera = ensure_open();
  if (!camera) {
    outcome.state = JobState::kFailed;
    outcome.failure_detail = camera.error().message;
    outcome.error = camera.error().with_context("camera " + this->id() + " is not available: ");
  } else {
    const CaptureJobEnv env = job_env();
    outcome = job.kind == "latency_probe" ? execute_latency_probe(**camera, job, env)
                                          : execute_capture(**camera, job, env);
  }
  running_job_ = 0;
  const bool gone = lost_.load() || (outcome.error && outcome.error->code == ErrorCode::kNoDevice &&
                                     outcome.state != JobState::kSucceeded);
  if (gone && outcome.state != JobState::kSucceeded) mark_device_lost(&outcome);
  if (outcome.device_failed && lost_.load()) {
    camera_.reset();  // retired: no reopen; the set serves it again when it is back
  } else if (outcome.device_failed) {
    log_warning(log::Category::kCameras, "camera %s failed during job %lld: %s", this->id().c_str(),
                static_cast<long long>(id),
                outcome.error ? outcome.error->message.c_str() : "device error");
    drop_camera(outcome.error.value_or(make_error("io_error", "device error")));
    // Reopen now, so the API shows at once whether the camera is back (an I/O error or
    // a stall) or gone (unplugged: the reopen fails and names why).
    if (auto reopened = ensure_open(); !reopened)
      log_warning(log::Category::kCameras, "camera %s: cannot reopen: %s", this->id().c_str(),
                  reopened.error().message.c_str());
  } else {
    refresh_snapshot();
  }
  previous_work_ = "job " + std::to_string(id) + " (" + job.kind + ")";
  previous_work_ended_unix_ms_ = unix_time_ms();
  auto finished = store_.finish(id, outcome.state, outcome.error, outcome.result);
  if (!finished)
    log_error(log::Category::kJobs, "job %lld: %s", static_cast<long long>(id),
              finished.error().message.c_str());
  log_info(log::Category::kJobs, "job %lld %s%s%s", static_cast<long long>(id),
           job_state_name(outcome.state), outcome.error ? ": " : "",
           outcome.error ? outcome.error->message.c_str() : "");
}

}  // namespace camlab::service
