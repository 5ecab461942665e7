// Calibration and analysis jobs (issues 5 and 6): CPU work on capture folders through
// calib/ and src/analysis, run one at a time on one compute thread (the machine's other
// cores stay for cameras and HTTP). Requests are validated and normalised by the
// handlers (service/api/api_compute.cpp); these functions trust them.
//
//   calibration request: {"source_folder": "captures/job-000012", "inner_corners": [14, 10],
//                         "spacing_m": 0.04, "model": "auto" | "LENSMODEL_...", "pixel_um": 4,
//                         "detector": "auto" | "opencv" | "mrgingham"}
//   analysis request:    {"source_folder": ..., "analysis": "defocus" | "exposure" | "focus"}
//
// Reentrant functions; ComputeWorker is thread-safe.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <mutex>
#include <thread>

#include "image/capture_folder.h"
#include "service/jobs/capture_job.h"
#include "service/store/job_store.h"

namespace camlab::service {

class Metrics;

// Writes the model into DATA/<job folder>/camera.cameramodel (and report.json); the
// job's result holds the report and the model text.

// `cancel`: set by another thread to stop the job between images and solve stages (a
// calibration) or between frames (an analysis); the outcome is then "cancelled" (the caller
// decides between cancelled and interrupted).
JobOutcome execute_calibration(const JobRecord& job, const std::filesystem::path& data_dir,
                               const std::atomic<bool>* cancel = nullptr);
JobOutcome execute_analysis(const JobRecord& job, const std::filesystem::path& data_dir,
                            const std::atomic<bool>* cancel = nullptr);

class ComputeWorker {
 public:
  ComputeWorker(std::filesystem::path data_dir, JobStore& store, Metrics& metrics,
                int max_queued_jobs = 16);
  ~ComputeWorker();
  void start();
  // Interrupts queued jobs and the running one (it stops after the image, frame or solve
  // stage in hand, well within a service manager's stop timeout); waits for it.
  void stop();
  Status enqueue_job(int64_t id);
  bool can_accept_job() const;
  // Requests that job `id` stop if it is the one running (DELETE /v1/jobs/{id}); false
  // otherwise.
  bool cancel_running(int64_t id);

 private:
  void run();
  // Puts job `id` back at the end of the queue after a second (at once on stop): the store
  // could not read or start it (`why`).
  void wait_for_store(int64_t id, const Error& why);

  const std::filesystem::path data_dir_;
  JobStore& store_;
  Metrics& metrics_;
  const int max_queued_jobs_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<int64_t> jobs_;
  bool stopping_ = false;
  std::atomic<int64_t> running_job_{0};
  std::atomic<bool> cancel_{false};  // the running job's stop request
  std::thread thread_;
};

}  // namespace camlab::service
