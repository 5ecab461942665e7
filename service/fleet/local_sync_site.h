// One camlabd's own cameras as the site of synchronised captures (sync_capture_site.h):
// a rig on one machine (camlabd --rig, or several USB cameras) captured at a common start
// with its jobs in the SQLite store, no fleet and no PostgreSQL needed. Camera ids are the
// host's own (GET /v1/cameras); every frame's start is on this host's one clock.
//
// Thread-safe: the job store and the camera set are.
#pragma once

#include "service/fleet/sync_capture_site.h"

namespace camlab::service {

class CameraSet;

class LocalSyncSite : public SyncCaptureSite {
 public:
  LocalSyncSite(JobStore& store, CameraSet& cameras) : store_(store), cameras_(cameras) {}

  Result<CameraTarget> resolve(const std::string& id) override;
  // Queued on the camera's worker, as POST /v1/cameras/{id}/captures queues it.
  Result<JobRecord> submit(const CameraTarget& target, const std::string& kind,
                           const nlohmann::json& request, int frames_total) override;
  JobStore& jobs() override { return store_; }
  void cancel_running(int64_t id) override;
  std::map<std::string, HostClock> clocks() override { return {}; }

 private:
  JobStore& store_;
  CameraSet& cameras_;
};

}  // namespace camlab::service
