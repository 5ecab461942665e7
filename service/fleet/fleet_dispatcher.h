// Hands this host's fleet jobs to its camera workers (docs/fleet.md, "Claiming"). It
// waits for the database's notifications (a job submitted for one of its cameras, a job of
// its own started or finished, a cancel request) and, at least every poll interval in any
// case:
//
// - claims the oldest waiting job for each camera whose worker has nothing queued, and
//   queues it there: a worker holds at most one job ahead, so the rest wait in the
//   database, where a host that dies does not take them with it;
// - queues again any job it has claimed that no worker holds (a claim whose commit was in
//   doubt when the connection broke, a job a worker dropped because the database was away
//   when it began it);
// - ends device_lost the jobs that wait for a camera this host no longer has;
// - passes cancel requests (DELETE /v1/jobs/{id} on another host) to the worker running
//   the job: a camera's, or the compute worker for a calibration or analysis;
// - hands other hosts' job changes to the job store's change observer, so that this
//   host's live job list shows the whole fleet's.
//
// Thread-safe: start() and stop() from the daemon's thread; one thread of its own.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <set>
#include <string>
#include <thread>

#include "service/store/fleet_store.h"

namespace camlab::service {

class CameraSet;
class CameraWorker;
class ComputeWorker;
class JobStore;
class FleetRegistry;

class FleetDispatcher {
 public:
  FleetDispatcher(FleetStore& fleet, JobStore& store, CameraSet& cameras, ComputeWorker& compute,
                  FleetRegistry& registry, std::chrono::milliseconds poll);
  ~FleetDispatcher();
  FleetDispatcher(const FleetDispatcher&) = delete;
  FleetDispatcher& operator=(const FleetDispatcher&) = delete;

  void start();
  void stop();

 private:
  void run();
  // What one notification asks for; true when this host may have work to claim.
  bool handle(const FleetNotice& notice);
  void claim_for_idle_cameras();
  void reconcile();
  // Asks whichever worker runs job `id` (camera `camera_id`'s; the compute worker's when
  // none) to stop it.
  void cancel_running(int64_t id, const std::string& camera_id);
  // Queues claimed job `id` on `worker`, or ends it with the reason it cannot be queued.
  void hand_over(int64_t id, const std::shared_ptr<CameraWorker>& worker,
                 const std::string& camera_id);

  FleetStore& fleet_;
  JobStore& store_;
  CameraSet& cameras_;
  ComputeWorker& compute_;
  FleetRegistry& registry_;
  const std::chrono::milliseconds poll_;
  std::set<int64_t> handed_;  // claimed jobs given to a worker, not yet seen started
  std::atomic<bool> stopping_{false};
  std::thread thread_;
};

}  // namespace camlab::service
