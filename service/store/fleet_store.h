// What a fleet of camlabd hosts shares in its database besides the jobs (PostgreSQL;
// postgres_fleet.h): the hosts with their leases, their cameras, the queue of work each
// host takes its jobs from, cancel requests, and the notifications that wake a host.
// docs/fleet.md is the user's account of it.
//
// - A host joins with a lease (a time on the database server's clock, so that the hosts'
//   clocks need not agree) and renews it every third of its length. A lease that has
//   passed is never renewed: its host must join again. Any live host expires the leases
//   that have passed and interrupts the unfinished jobs of their hosts; each job's
//   conditional UPDATE makes that happen exactly once, whichever host gets there first.
// - A job for a camera is submitted for the camera's host (from any host) and waits
//   unclaimed; the host takes it when that camera's worker has nothing queued (claim(),
//   `FOR UPDATE SKIP LOCKED`), so a job is run by one host once. A host that dies before
//   claiming them leaves its jobs waiting until its lease expires.
// - Every change of a job's state, its progress rows and cancel requests are notified on
//   the channel "camlab_jobs" (a trigger, so that no writer can forget it), and every
//   state change is kept in job_events (the history that shows a job ended once).
//
// Thread-safe: one connection of its own behind a mutex (apart from the job store's, so
// that lease renewals never wait behind job traffic); a FleetListener has a third.
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "base/result.h"
#include "service/store/job_store.h"

namespace camlab::service {

// A camera as its host publishes it: enough for any host to check a capture request
// against it (service/fleet/camera_description.h) and to show it.
struct FleetCamera {
  std::string host;
  std::string camera_id;       // the id on its host ("v4l2:platform:camlab-vcam-0")
  nlohmann::json description;  // identity, formats, controls, traits
  bool available = false;
  int64_t running_job = 0;
  int queued_jobs = 0;
};

struct FleetHost {
  std::string name;
  std::string url;    // where its API is reached (frames are fetched there)
  std::string state;  // "live", "expired" (lease passed), "left" (stopped cleanly)
  int64_t started_ms = 0;
  int lease_ms = 0;
  int64_t lease_remaining_ms = 0;  // on the server's clock; negative once passed
  int64_t renewed_ago_ms = 0;
  // This host's clock minus the database server's, measured at the last renewal
  // (round trip / 2 as its uncertainty).
  int64_t clock_offset_us = 0, clock_uncertainty_us = 0;
  std::vector<FleetCamera> cameras;
  // A live host without a URL holds its name while it starts: it does not serve yet.
  bool starting() const { return state == "live" && url.empty(); }
  bool serving() const { return state == "live" && !url.empty(); }
};

struct LeaseRenewal {
  bool renewed = false;  // false: the lease had passed (or was taken over): join again
  int64_t clock_offset_us = 0, clock_uncertainty_us = 0;
};

struct ExpiredHost {
  std::string name;
  std::vector<int64_t> jobs_interrupted;
};

// A job-related notification from the database.
struct FleetNotice {
  std::string channel;          // "camlab_jobs" or "camlab_fleet"
  nlohmann::json payload;       // jobs: {id, state, host, camera_id, frames_*, cancel}
  bool from_own_store = false;  // sent by this host's own job store (already seen locally)
};

// Waits for notifications on a connection of its own. Thread-compatible (one thread).
class FleetListener {
 public:
  virtual ~FleetListener() = default;
  // The notifications that came within `timeout` (none: empty); database_unavailable
  // while the connection is down (notifications sent meanwhile are lost: the caller polls).
  virtual Result<std::vector<FleetNotice>> wait(std::chrono::milliseconds timeout) = 0;
};

class FleetStore {
 public:
  virtual ~FleetStore() = default;

  // This host's name in the fleet.
  virtual const std::string& host() const = 0;

  // Takes this host's name for its identity (PostgresStoreOptions::host_identity) before
  // the host touches any job of that name: a new incarnation, live for `lease`, its URL
  // not yet known. Error "exists" when a live host of another identity holds the name
  // (a clone started with the same --host-name): that one keeps it, and nothing of it is
  // touched. The same identity (a restart after a crash) takes it over at once.
  virtual Status hold_name(std::chrono::milliseconds lease) = 0;
  // Registers this host (again) with a fresh incarnation, reachable at `url`, with a lease
  // of `lease` from now on the server's clock; "exists" as hold_name().
  virtual Status join(const std::string& url, std::chrono::milliseconds lease) = 0;
  // Extends the lease if it has not passed, and measures the clock offset.
  virtual Result<LeaseRenewal> renew() = 0;
  // Leaves the fleet (a clean stop): this host's unfinished jobs, waiting ones included,
  // end interrupted with `message`.
  virtual Status leave(const std::string& message) = 0;
  // Expires every lease that has passed and interrupts its host's unfinished jobs; also
  // interrupts jobs still unfinished on a host that is not live (submitted as it expired).
  virtual Result<std::vector<ExpiredHost>> expire_hosts() = 0;
  // While fenced (this host could not renew its lease in time), the job store refuses to
  // start or finish this host's jobs (database_unavailable): it takes no new work, and a
  // job it stopped ends as the fleet ends it (interrupted), not as the local cancel would.
  // Progress rows still go through (a job no longer running takes none).
  virtual void set_fenced(bool fenced) = 0;
  virtual bool fenced() const = 0;

  // Replaces this host's published cameras.
  virtual Status publish_cameras(const std::vector<FleetCamera>& cameras) = 0;
  // Every host ever joined, with its cameras.
  virtual Result<std::vector<FleetHost>> hosts() = 0;

  // A queued job for camera `camera_id` of `host`, waiting to be claimed there;
  // "host_unavailable" when that host is not live.
  virtual Result<JobRecord> submit(const std::string& host, const std::string& kind,
                                   const std::string& camera_id, const nlohmann::json& request,
                                   const std::string& folder_prefix, int frames_total) = 0;
  // Up to `limit` waiting jobs of this host for `camera_id`, oldest first, now this host's
  // to run (start() then moves each to running).
  virtual Result<std::vector<int64_t>> claim(const std::string& camera_id, int limit) = 0;
  // The cameras of this host that unclaimed jobs wait for (a camera the host no longer
  // has is found this way: its jobs are claimed and ended device_lost).
  virtual Result<std::vector<std::string>> waiting_cameras() = 0;
  // How many jobs wait (unclaimed) for `camera_id` of `host`.
  virtual Result<int> waiting(const std::string& host, const std::string& camera_id) = 0;
  // This host's claimed camera jobs (captures, latency probes) still queued: each must be
  // in a camera worker's queue (a claim whose commit was in doubt when the connection broke
  // is found here and queued after all). Compute jobs are not: they wait in the compute
  // queue.
  virtual Result<std::vector<int64_t>> claimed_waiting() = 0;

  // Asks the host running job `id` to cancel it; false when it is not running.
  virtual Result<bool> request_cancel(int64_t id) = 0;
  // This host's running jobs with a cancel request: (id, camera id).
  virtual Result<std::vector<std::pair<int64_t, std::string>>> cancel_requests() = 0;

  // This host's jobs a previous run of it left for folder recovery: unfinished ones, and
  // those interrupted by the fleet since that run started.
  virtual Result<std::vector<JobRecord>> jobs_to_recover() = 0;
  // Sets the frame count of this host's job `id`, interrupted meanwhile, to what its
  // recovered folder lists.
  virtual Status set_recovered_frames(int64_t id, int frames) = 0;

  // A listener on the job and fleet channels, on its own connection.
  virtual Result<std::unique_ptr<FleetListener>> listen() = 0;
};

}  // namespace camlab::service
