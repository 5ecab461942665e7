// Where a synchronised capture's cameras are (sync_captures.h): the fleet (fleet.h: cameras
// on any host, jobs in PostgreSQL) or this camlabd alone (local_sync_site.h: its own
// cameras, jobs in its SQLite store), so a rig on one machine needs no database server.
//
// Thread-safe, as the implementations are.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "base/result.h"
#include "capture/capture_plan.h"
#include "service/fleet/camera_description.h"
#include "service/fleet/fleet_registry.h"
#include "service/jobs/sync_schedule.h"
#include "service/store/job_store.h"

namespace camlab::service {

class CameraWorker;
struct CameraSnapshot;

// A camera of the site, found by its id.
struct CameraTarget {
  std::string host;                      // its host ("" for a camlabd alone)
  std::string camera_id;                 // its id on that host
  std::shared_ptr<CameraWorker> worker;  // this host's camera; null for another host's
  PublishedCamera camera;                // what a capture request is checked against
  nlohmann::json description;            // as its host published it
  bool available = false;
  std::string unavailable_reason;

  // CAMERA@HOST in a fleet, CAMERA alone.
  std::string fleet_id() const {
    return host.empty() ? camera_id : fleet_camera_id(camera_id, host);
  }
};

// The target of a camera this camlabd serves (`host` its name in a fleet, "" alone), from
// the worker's snapshot: what a capture request is checked against and whether it is
// available; `describe` gives the description the site publishes.
CameraTarget local_camera_target(
    std::shared_ptr<CameraWorker> worker, const std::string& host,
    const std::function<nlohmann::json(const CameraSnapshot&)>& describe);

class SyncCaptureSite {
 public:
  virtual ~SyncCaptureSite() = default;
  // The camera `id` names; "not_found" listing the cameras there are.
  virtual Result<CameraTarget> resolve(const std::string& id) = 0;
  // `request` checked as a capture for the camera, as its host would check it (against
  // the controls, formats and traits the target carries, wherever the camera is).
  Result<capture::CapturePlan> plan(const CameraTarget& target,
                                    const nlohmann::json& request) const {
    return capture::plan_capture(request, target.camera.controls, target.camera.formats,
                                 target.camera.traits);
  }
  // A job for the camera (queued for it). Errors: "no_device", "too_many_jobs", ...
  virtual Result<JobRecord> submit(const CameraTarget& target, const std::string& kind,
                                   const nlohmann::json& request, int frames_total) = 0;
  virtual JobStore& jobs() = 0;
  // Asks whoever runs job `id` to stop it (it ends cancelled).
  virtual void cancel_running(int64_t id) = 0;
  // The hosts' clocks against the common one, by host (empty for one host: one clock).
  virtual std::map<std::string, HostClock> clocks() = 0;
};

}  // namespace camlab::service
