// A camlabd host in a fleet (`--db postgresql://...`, docs/fleet.md): its membership
// (fleet_member.h), the dispatcher that hands it its jobs (fleet_dispatcher.h), the view of
// the other hosts (fleet_registry.h), synchronised captures (sync_captures.h), and what
// the API asks of the fleet: a camera by its fleet id, and a job submitted for it,
// whichever host has it.
//
// Thread-safe: start() and stop() from the daemon's thread, the rest from any.
#pragma once

#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "base/result.h"
#include "capture/capture_plan.h"
#include "service/fleet/camera_description.h"
#include "service/fleet/fleet_dispatcher.h"
#include "service/fleet/fleet_member.h"
#include "service/fleet/fleet_registry.h"
#include "service/fleet/sync_capture_site.h"
#include "service/store/fleet_store.h"

namespace camlab::service {

class CameraSet;
class CameraWorker;
class ComputeWorker;
class JobStore;
class SyncCaptures;

class Fleet : public SyncCaptureSite {
 public:
  // `compute` runs this host's calibrations and analyses (a cancel request for one reaches
  // it through the fleet).
  Fleet(FleetStore& fleet, JobStore& store, CameraSet& cameras, ComputeWorker& compute,
        FleetOptions options, int max_queued_jobs);
  ~Fleet();
  Fleet(const Fleet&) = delete;
  Fleet& operator=(const Fleet&) = delete;

  // Joins the fleet as reachable at `url` and starts taking jobs (FleetMember::start).
  Status start(const std::string& url);
  // Takes no more jobs (before the workers stop) ...
  void stop_taking_jobs();
  // ... and leaves the fleet once they have: what is left of this host's ends interrupted.
  void leave(const std::string& message);

  const std::string& host() const { return options_.host; }
  FleetStore& store() { return fleet_; }
  JobStore& jobs() override { return store_; }
  FleetRegistry& registry() { return registry_; }
  SyncCaptures& sync() { return *sync_; }

  // The camera `id` names: "CAMERA@HOST", or "CAMERA" for one of this host's. Errors:
  // "not_found" (listing the cameras), "host_unavailable" (its host is not serving).
  Result<CameraTarget> resolve(const std::string& id) override;
  // A job for the camera, waiting for its host to claim it. Errors: "no_device" (the
  // camera is not available), "too_many_jobs" (more than max_queued_jobs wait for it),
  // "host_unavailable", "database_unavailable".
  Result<JobRecord> submit(const CameraTarget& target, const std::string& kind,
                           const nlohmann::json& request, int frames_total) override;
  // A running job, here or on another host: its host's dispatcher passes the request on.
  void cancel_running(int64_t id) override;
  // Each live host's clock offset to the database's.
  std::map<std::string, HostClock> clocks() override;
  // Where host `name`'s API is reached, or "host_unavailable" when it is not live.
  Result<std::string> url_of(const std::string& name);

 private:
  FleetStore& fleet_;
  JobStore& store_;
  CameraSet& cameras_;
  const FleetOptions options_;
  const int max_queued_jobs_;
  FleetRegistry registry_;
  FleetMember member_;
  FleetDispatcher dispatcher_;
  std::unique_ptr<SyncCaptures> sync_;
};

}  // namespace camlab::service
