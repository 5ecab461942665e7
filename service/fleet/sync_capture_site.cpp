#include "service/fleet/sync_capture_site.h"

#include "service/jobs/camera_worker.h"

namespace camlab::service {

CameraTarget local_camera_target(
    std::shared_ptr<CameraWorker> worker, const std::string& host,
    const std::function<nlohmann::json(const CameraSnapshot&)>& describe) {
  const CameraSnapshot s = worker->snapshot();
  CameraTarget target;
  target.host = host;
  target.camera_id = worker->id();
  target.camera = {s.controls, s.formats, s.traits};
  target.description = describe(s);
  target.available = s.available && !s.gone;
  target.unavailable_reason = s.unavailable_reason;
  target.worker = std::move(worker);
  return target;
}

}  // namespace camlab::service
