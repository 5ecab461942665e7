// What the route handlers share: the data folder, the job store, the cameras, the compute
// worker and the metrics. Owned by the Daemon (service/daemon.h); handlers borrow it for
// the daemon's lifetime.
#pragma once

#include <filesystem>
#include <string>

#include "service/api/router.h"

namespace camlab::service {

class CalibrationSessions;
class CameraSet;
class ComputeWorker;
class Fleet;
class SyncCaptures;
class JobStore;
class JobEvents;
class JobWaiters;
class LiveHub;
class Metrics;

struct ServiceContext {
  std::filesystem::path data_dir;  // canonical
  JobStore* store = nullptr;
  CameraSet* cameras = nullptr;
  ComputeWorker* compute = nullptr;
  Metrics* metrics = nullptr;
  bool test_faults = false;                 // POST /v1/test/cameras/{id}/faults is registered
  CalibrationSessions* sessions = nullptr;  // null: /v1/calibration-sessions answers 503
  JobWaiters* waiters = nullptr;            // null: GET /v1/jobs/{id}?wait= answers at once
  LiveHub* live = nullptr;      // null: live views, histograms and thumbnails answer 503
  JobEvents* events = nullptr;  // null: GET /v1/events answers 503
  Fleet* fleet = nullptr;       // null: one camlabd (SQLite); /v1/fleet answers unsupported
  // Synchronised captures of this camlabd's own cameras when it is no fleet host (a
  // fleet's are fleet->sync()); null: POST /v1/sync-captures answers not_in_a_fleet.
  SyncCaptures* sync = nullptr;
};

// Registration of each group of routes (one file each).
void add_system_routes(Router& router, const ServiceContext& context);    // api_system.cpp
void add_camera_routes(Router& router, const ServiceContext& context);    // api_cameras.cpp
void add_job_routes(Router& router, const ServiceContext& context);       // api_jobs.cpp
void add_job_file_routes(Router& router, const ServiceContext& context);  // api_job_files.cpp
void add_compute_routes(Router& router, const ServiceContext& context);   // api_compute.cpp
void add_test_routes(Router& router, const ServiceContext& context);      // api_test_faults.cpp
void add_session_routes(Router& router, const ServiceContext& context);   // api_sessions.cpp
void add_live_routes(Router& router, const ServiceContext& context);      // api_live.cpp
void add_frame_region_routes(Router& router,
                             const ServiceContext& context);           // api_frame_region.cpp
void add_event_routes(Router& router, const ServiceContext& context);  // api_events.cpp
void add_web_routes(Router& router, const ServiceContext& context);    // api_web.cpp
// The fleet's routes; on a fleet host also wraps the camera and job routes added before.
void add_fleet_routes(Router& router, const ServiceContext& context);  // api_fleet.cpp

// Every route of the daemon, in the order they are matched (test routes only with
// context.test_faults).
void add_all_routes(Router& router, const ServiceContext& context);

// The OpenAPI 3 document of the routes (service/api/openapi.cpp); with test routes marked
// "x-test-only" when `include_test_routes`.
nlohmann::json openapi_document(bool include_test_routes);

}  // namespace camlab::service
