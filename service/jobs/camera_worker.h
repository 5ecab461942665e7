// One worker thread per camera: it opens and owns the Camera (thread-bound), runs that
// camera's jobs one at a time in the order they were queued, and runs short tasks (set
// controls) between jobs. Cameras run in parallel, each on its own worker.
//
// What HTTP handlers may read without waiting for the camera is kept in a snapshot
// (identity, formats, controls with ranges, availability, the running job), refreshed
// by the worker after opening the camera, after each job and after each control change.
//
// A device error during a job (I/O error, timeout) fails that job; the worker then drops
// the camera and reopens it before the next job, so one fault never poisons the next
// capture. A camera that is gone (ENODEV: "no_device") ends the job device_lost instead,
// with its frames kept. stop() cancels the running job (it ends interrupted), turns queued
// jobs into interrupted and joins the thread.
//
// Hot-plug (service/jobs/camera_set.h): when the camera set's rescan no longer finds the
// camera it retires the worker: retire() cancels the running job, which ends device_lost
// with the reason (frames kept), ends the queued jobs device_lost, and lets the thread
// finish on its own; the set joins it once finished() (join()). A retired worker stays
// listed as gone until a fresh worker for the same id replaces it.
//
// Live view (service/live/): the worker owns the camera's LiveFeed. Captures offer it their
// frames as they dequeue them; with no job and no task queued, while the feed is wanted
// (someone watches), the worker previews: it streams the camera and offers the frames,
// running control changes between frames, and stops streaming as soon as a job is queued
// or nobody watches any more.
//
// Owned by the camera set through shared_ptr; HTTP handlers hold a copy for the length of
// a request, so a worker retired meanwhile stays valid (it refuses new work).
// Thread-safe (every public member); the camera itself is touched only on the worker.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "base/result.h"
#include "capture/capture_plan.h"
#include "device/camera.h"
#include "device/device_registry.h"
#include "service/jobs/capture_job.h"
#include "service/live/live_feed.h"

namespace camlab::service {

class JobStore;
class Metrics;
struct JobOutcome;

struct CameraSnapshot {
  device::CameraIdentity identity;
  std::string transport;  // "kernel", "in-process virtual camera", ...
  bool available = false;
  std::string unavailable_reason;
  std::vector<device::ControlInfo> controls;
  std::vector<device::PixelFormatInfo> formats;
  nlohmann::json description;    // device::describe_camera, as of the last refresh
  capture::CameraTraits traits;  // what raw values mean (bit depth, f-numbers), when known
  int64_t running_job = 0;       // 0 when idle
  // The control latency is being measured (at start-up, for a camera the database has no
  // latency for); jobs and control changes wait for it.
  bool measuring_latency = false;
  int queued_jobs = 0;
  std::string also_reachable_as;  // the same camera's id under the other backend
  bool gone = false;              // retired: the camera was unplugged (no longer found)
  int64_t gone_since_ms = 0;      // Unix time of the retirement
};

struct CameraWorkerOptions {
  std::filesystem::path data_dir;
  // The control latency the camera's specification states (the in-process virtual
  // camera's); still probed, and the larger of the two is used.
  std::optional<int> spec_latency_frames;
  nlohmann::json source_extra = nlohmann::json::object();  // added to each manifest's source
  capture::CameraTraits traits;  // from the virtual camera's spec, or --device-spec
  int max_queued_jobs = 32;
  std::chrono::milliseconds frame_timeout{5000};
};

class CameraWorker {
 public:
  using OpenCamera = std::function<Result<std::unique_ptr<device::Camera>>()>;
  // Runs on the worker thread with the open camera, or with nullptr and why it is not.
  using Task = std::function<void(device::Camera* camera, const Error* unavailable)>;

  CameraWorker(device::DeviceEntry entry, OpenCamera open, CameraWorkerOptions options,
               JobStore& store, Metrics& metrics);
  ~CameraWorker();
  CameraWorker(const CameraWorker&) = delete;
  CameraWorker& operator=(const CameraWorker&) = delete;

  // Starts the thread; it opens the camera and takes the first snapshot. Waits (bounded)
  // for that first snapshot so the API never lists a camera it knows nothing about.
  void start();
  // Cancels the running job (it ends interrupted) and wakes the worker to interrupt the
  // queued jobs; stop() also joins.
  void request_stop();
  void stop();

  // The camera is gone (see the header comment): `reason` is stored with every job it
  // ends. Does not wait for the thread. Idempotent.
  void retire(const std::string& reason);
  bool retired() const;
  // The thread has returned (after retire() or stop()); join() then does not block.
  bool finished() const { return finished_.load(); }
  void join();

  const std::string& id() const { return entry_.identity.id; }
  const device::DeviceEntry& entry() const { return entry_; }
  CameraSnapshot snapshot() const;
  // The camera's live feed; closed once the worker is retired or stopped.
  const std::shared_ptr<LiveFeed>& live_feed() const { return live_; }

  // Queues a task ahead of queued jobs; "shutting_down" once stopping.
  Status post_task(Task task);
  // post_task, then `then` on the worker once the snapshot holds what the task changed: a
  // reply sent from `then` is never ahead of GET /v1/cameras/{id} (controls read back).
  Status post_task(Task task, std::function<void()> then);
  // The camera set found the device present: if the camera is unavailable (it failed to
  // open, or a job lost it), try opening it again, unless a try is already queued.
  void reopen_if_unavailable();
  // Queues job `id` (already stored as queued); "too_many_jobs", "shutting_down", or
  // "no_device" once retired.
  Status enqueue_job(int64_t id);
  // Whether enqueue_job would take a job now; the error it would give otherwise.
  Status can_accept_job() const;
  // Stores a job of `kind` for this camera in `store` and queues it: what
  // POST /v1/cameras/{id}/captures and a synchronised capture's children both do. A job
  // the queue refuses after it was stored ends cancelled with the refusal, which is
  // returned; a refusal before storing stores nothing.
  Result<JobRecord> store_and_enqueue(JobStore& store, const std::string& kind,
                                      const nlohmann::json& request, int frames_total);
  // Requests cancellation of job `id` if it is the one running; false otherwise.
  bool cancel_running(int64_t id);
  // Takes job `id` out of the queue (it was cancelled while queued), so that its slot is
  // free for the next submission at once, not when the worker reaches it.
  void forget_queued(int64_t id);

 private:
  void run();
  void run_job(int64_t id);
  // Streams for the live feed while it is wanted and nothing else is queued.
  void run_preview();
  // Runs the queued tasks (between preview frames).
  void run_queued_tasks();
  // A camera with no control latency in the database is probed as soon as it opens, before
  // any job (which queue meanwhile, as do control changes), so that the first capture
  // does not carry the probe's seconds as a surprise.
  void probe_latency_at_startup(device::Camera& camera);
  CaptureJobEnv job_env();
  // The open camera, opening it if needed (updates the snapshot's availability).
  Result<device::Camera*> ensure_open();
  void drop_camera(const Error& why);
  void refresh_snapshot();
  // Ends queued job `id` without running it (shutdown or retirement).
  void end_unstarted(int64_t id);
  // Turns a job's outcome into device_lost, with the reason and the frames kept.
  void mark_device_lost(JobOutcome* outcome) const;

  const device::DeviceEntry entry_;
  const OpenCamera open_;
  const CameraWorkerOptions options_;
  JobStore& store_;
  Metrics& metrics_;

  std::unique_ptr<device::Camera> camera_;  // worker thread only
  // The worker's last piece of work ("measuring its control latency at start-up", "job
  // 12 (capture)") and when it ended, realtime ms: worker thread only (job_env()).
  std::string previous_work_;
  int64_t previous_work_ended_unix_ms_ = 0;
  const std::shared_ptr<LiveFeed> live_;

  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<Task> tasks_;
  std::deque<int64_t> jobs_;
  bool stopping_ = false;
  bool started_snapshot_ = false;
  CameraSnapshot snapshot_;

  std::atomic<int64_t> running_job_{0};
  std::atomic<bool> cancel_{false};
  std::atomic<bool> shutting_down_{false};
  std::atomic<bool> lost_{false};  // retired: the running job ends device_lost
  std::string lost_reason_;        // under mutex_
  std::atomic<bool> finished_{false};
  std::thread thread_;
};

}  // namespace camlab::service
