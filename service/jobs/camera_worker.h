// One worker thread per camera: it opens and owns the Camera (thread-bound), runs that
// camera's jobs one at a time in the order they were queued, and runs short tasks (set
// controls) between jobs. Cameras run in parallel, each on its own worker.
//
// What HTTP handlers may read without waiting for the camera is kept in a snapshot
// (identity, formats, controls with ranges, availability, the running job), refreshed
// by the worker after opening the camera, after each job and after each control change.
//
// A device error during a job (unplugged, I/O error, timeout) fails that job; the worker
// then drops the camera and reopens it before the next job, so one fault never poisons
// the next capture. stop() cancels the running job (it ends interrupted), turns queued
// jobs into interrupted and joins the thread.
//
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

namespace camlab::service {

class JobStore;
class Metrics;

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
  int queued_jobs = 0;
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

  const std::string& id() const { return entry_.identity.id; }
  CameraSnapshot snapshot() const;

  // Queues a task ahead of queued jobs; "shutting_down" once stopping.
  Status post_task(Task task);
  // Queues job `id` (already stored as queued); "too_many_jobs" or "shutting_down".
  Status enqueue_job(int64_t id);
  bool can_accept_job() const;
  // Requests cancellation of job `id` if it is the one running; false otherwise.
  bool cancel_running(int64_t id);

 private:
  void run();
  void run_job(int64_t id);
  // The open camera, opening it if needed (updates the snapshot's availability).
  Result<device::Camera*> ensure_open();
  void drop_camera(const Error& why);
  void refresh_snapshot();

  const device::DeviceEntry entry_;
  const OpenCamera open_;
  const CameraWorkerOptions options_;
  JobStore& store_;
  Metrics& metrics_;

  std::unique_ptr<device::Camera> camera_;  // worker thread only

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
  std::thread thread_;
};

}  // namespace camlab::service
