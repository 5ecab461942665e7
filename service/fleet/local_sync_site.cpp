#include "service/fleet/local_sync_site.h"

#include "service/jobs/camera_set.h"
#include "service/jobs/camera_worker.h"

namespace camlab::service {

Result<CameraTarget> LocalSyncSite::resolve(const std::string& id) {
  std::shared_ptr<CameraWorker> worker = cameras_.find(id);
  if (!worker) {
    std::string known;
    for (const auto& w : cameras_.workers()) known += (known.empty() ? "" : ", ") + w->id();
    return make_error("not_found", "no camera '" + id.substr(0, 100) +
                                       "' (cameras: " + (known.empty() ? "none" : known) + ")");
  }
  return local_camera_target(std::move(worker), "",
                             [](const CameraSnapshot& s) { return s.description; });
}

Result<JobRecord> LocalSyncSite::submit(const CameraTarget& target, const std::string& kind,
                                        const nlohmann::json& request, int frames_total) {
  if (!target.available || !target.worker)
    return make_error("no_device", "camera " + target.camera_id +
                                       " is not available: " + target.unavailable_reason);
  return target.worker->store_and_enqueue(store_, kind, request, frames_total);
}

void LocalSyncSite::cancel_running(int64_t id) {
  for (const auto& worker : cameras_.workers())
    if (worker->cancel_running(id)) return;
}

}  // namespace camlab::service
