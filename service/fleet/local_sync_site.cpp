#include "service/fleet/local_sync_site.h"

#include "service/jobs/camera_set.h"
#include "service/jobs/camera_worker.h"

namespace camlab::service {

Result<CameraTarget> LocalSyncSite::resolve(const std::string& id) {
  CameraTarget target;
  target.camera_id = id;
  target.worker = cameras_.find(id);
  if (!target.worker) {
    std::string known;
    for (const auto& worker : cameras_.workers())
      known += (known.empty() ? "" : ", ") + worker->id();
    return make_error("not_found", "no camera '" + id.substr(0, 100) +
                                       "' (cameras: " + (known.empty() ? "none" : known) + ")");
  }
  const CameraSnapshot s = target.worker->snapshot();
  target.camera = {s.controls, s.formats, s.traits};
  target.description = s.description;
  target.available = s.available && !s.gone;
  target.unavailable_reason = s.unavailable_reason;
  return target;
}

Result<JobRecord> LocalSyncSite::submit(const CameraTarget& target, const std::string& kind,
                                        const nlohmann::json& request, int frames_total) {
  if (!target.available || !target.worker)
    return make_error("no_device", "camera " + target.camera_id +
                                       " is not available: " + target.unavailable_reason);
  if (Status accepted = target.worker->can_accept_job(); !accepted) return accepted.error();
  auto job = store_.create(kind, target.worker->id(), request,
                           kind == "capture" ? "captures/job-" : "", frames_total);
  if (!job) return job.error();
  if (Status queued = target.worker->enqueue_job(job->id); !queued) {
    (void)store_.finish(job->id, JobState::kCancelled, queued.error(), nullptr);
    return queued.error();
  }
  return job;
}

void LocalSyncSite::cancel_running(int64_t id) {
  for (const auto& worker : cameras_.workers())
    if (worker->cancel_running(id)) return;
}

}  // namespace camlab::service
