#include "service/fleet/fleet_dispatcher.h"

#include <algorithm>
#include <vector>

#include "base/log.h"
#include "service/fleet/fleet_registry.h"
#include "service/jobs/camera_set.h"
#include "service/jobs/compute_jobs.h"
#include "service/store/job_store.h"

namespace camlab::service {

namespace {

using Clock = std::chrono::steady_clock;

// Jobs for one camera this host no longer has, ended per pass.
constexpr int kStraysPerPass = 64;

}  // namespace

FleetDispatcher::FleetDispatcher(FleetStore& fleet, JobStore& store, CameraSet& cameras,
                                 ComputeWorker& compute, FleetRegistry& registry,
                                 std::chrono::milliseconds poll)
    : fleet_(fleet),
      store_(store),
      cameras_(cameras),
      compute_(compute),
      registry_(registry),
      poll_(poll) {}

FleetDispatcher::~FleetDispatcher() { stop(); }

void FleetDispatcher::start() {
  thread_ = std::thread([this] { run(); });
}

void FleetDispatcher::stop() {
  stopping_ = true;
  if (thread_.joinable()) thread_.join();
}

void FleetDispatcher::run() {
  std::unique_ptr<FleetListener> listener;
  Clock::time_point next_poll = Clock::now();
  std::string last_error;
  while (!stopping_) {
    if (!listener) {
      auto made = fleet_.listen();
      if (made) listener = std::move(*made);
    }
    bool work = false;
    const auto timeout =
        std::max(std::chrono::milliseconds(1),
                 std::chrono::duration_cast<std::chrono::milliseconds>(next_poll - Clock::now()));
    auto notices = listener ? listener->wait(timeout)
                            : Result<std::vector<FleetNotice>>(make_error("internal", "none"));
    if (!notices) {
      // Down: notifications sent meanwhile are lost, so the poll below finds the work.
      if (notices.error().message != last_error)
        log_warning(log::Category::kJobs, "fleet: waiting for notifications: %s",
                    notices.error().message.c_str());
      last_error = notices.error().message;
      std::this_thread::sleep_for(std::min(poll_, std::chrono::milliseconds(200)));
    } else {
      last_error.clear();
      for (const FleetNotice& notice : *notices) work = handle(notice) || work;
    }
    const bool poll_due = Clock::now() >= next_poll;
    if (fleet_.fenced()) continue;
    if (work || poll_due) claim_for_idle_cameras();
    if (poll_due) {
      reconcile();
      next_poll = Clock::now() + poll_;
    }
  }
}

bool FleetDispatcher::handle(const FleetNotice& notice) {
  if (notice.channel == "camlab_fleet") {
    (void)registry_.refresh();  // a host joined, left or expired: API lookups see it now
    return true;
  }
  if (notice.channel != "camlab_jobs" || !notice.payload.is_object()) return false;
  const nlohmann::json& p = notice.payload;
  const std::optional<JobState> state = parse_job_state(p.value("state", ""));
  if (!state) return false;
  // This host's store told its observer already; the rest is news here.
  if (!notice.from_own_store)
    store_.relay_change({p.value("id", int64_t{0}), *state, p.value("frames_done", 0),
                         p.value("frames_total", 0), p.value("frames_discarded", 0)});
  if (p.value("host", "") != fleet_.host()) return false;
  if (*state == JobState::kRunning && p.value("cancel", false))
    cancel_running(p.value("id", int64_t{0}), p.value("camera_id", ""));
  return true;
}

void FleetDispatcher::cancel_running(int64_t id, const std::string& camera_id) {
  // A calibration or analysis has no camera: the compute worker runs it.
  if (camera_id.empty()) {
    compute_.cancel_running(id);
    return;
  }
  if (auto worker = cameras_.find(camera_id)) worker->cancel_running(id);
}

void FleetDispatcher::hand_over(int64_t id, const std::shared_ptr<CameraWorker>& worker,
                                const std::string& camera_id) {
  Status queued = worker ? worker->enqueue_job(id)
                         : Status(make_error("no_device", "camera " + camera_id +
                                                              " is not on host " + fleet_.host()));
  if (queued) {
    handed_.insert(id);
    return;
  }
  // As on one camlabd: a camera that is gone ends the job device_lost, a stopping host
  // interrupted.
  const Error& why = queued.error();
  const JobState state = why.code == ErrorCode::kNoDevice       ? JobState::kDeviceLost
                         : why.code == ErrorCode::kShuttingDown ? JobState::kInterrupted
                                                                : JobState::kFailed;
  const Error stored = why.code == ErrorCode::kNoDevice ? Error(ErrorCode::kDeviceLost, why.message)
                       : why.code == ErrorCode::kShuttingDown
                           ? Error(ErrorCode::kInterrupted, why.message)
                           : why;
  if (auto ended = store_.finish(id, state, stored, nullptr); !ended)
    log_warning(log::Category::kJobs, "job %lld: %s", static_cast<long long>(id),
                ended.error().message.c_str());
}

void FleetDispatcher::claim_for_idle_cameras() {
  for (const auto& worker : cameras_.workers()) {
    if (stopping_) return;
    if (worker->snapshot().queued_jobs > 0) continue;
    auto claimed = fleet_.claim(worker->id(), 1);
    if (!claimed) {
      log_warning(log::Category::kJobs, "fleet: claiming for camera %s: %s", worker->id().c_str(),
                  claimed.error().message.c_str());
      return;
    }
    for (int64_t id : *claimed) hand_over(id, worker, worker->id());
  }
}

void FleetDispatcher::reconcile() {
  // Claimed and still queued, but in no worker's queue: a claim whose commit was in doubt,
  // or a job its worker dropped because the database was away when it began it. Queued
  // (again) on its camera's worker when that holds no job: a job queued twice is started
  // once (start() is conditional), so a worker that had it after all skips the second.
  // Jobs seen started or ended leave handed_.
  if (auto waiting = fleet_.claimed_waiting()) {
    std::set<int64_t> still(waiting->begin(), waiting->end());
    std::erase_if(handed_, [&](int64_t id) { return !still.contains(id); });
    for (int64_t id : *waiting) {
      auto job = store_.get(id);
      if (!job || !job->has_value()) continue;
      auto worker = cameras_.find((*job)->camera_id);
      if (handed_.contains(id) && worker) {
        const CameraSnapshot s = worker->snapshot();
        if (s.queued_jobs > 0 || s.running_job != 0) continue;  // it may still have it
      }
      hand_over(id, worker, (*job)->camera_id);
    }
  }
  // Jobs waiting for a camera this host does not have (any more): ended device_lost.
  if (auto cameras = fleet_.waiting_cameras()) {
    for (const std::string& camera : *cameras) {
      if (cameras_.find(camera)) continue;
      auto claimed = fleet_.claim(camera, kStraysPerPass);
      if (!claimed) break;
      for (int64_t id : *claimed) hand_over(id, nullptr, camera);
    }
  }
  if (auto requests = fleet_.cancel_requests())
    for (const auto& [id, camera] : *requests) cancel_running(id, camera);
}

}  // namespace camlab::service
