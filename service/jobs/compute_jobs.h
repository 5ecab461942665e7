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
// The pixel pitch (um) a capture folder's manifest knows (the virtual camera's spec), else 0.
double manifest_pixel_pitch_um(const image::CaptureFolder& folder);

JobOutcome execute_calibration(const JobRecord& job, const std::filesystem::path& data_dir);
JobOutcome execute_analysis(const JobRecord& job, const std::filesystem::path& data_dir);

class ComputeWorker {
 public:
  ComputeWorker(std::filesystem::path data_dir, JobStore& store, Metrics& metrics,
                int max_queued_jobs = 16);
  ~ComputeWorker();
  void start();
  void stop();  // interrupts queued jobs; waits for the running one (it cannot be cut short)
  Status enqueue_job(int64_t id);
  bool can_accept_job() const;

 private:
  void run();

  const std::filesystem::path data_dir_;
  JobStore& store_;
  Metrics& metrics_;
  const int max_queued_jobs_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<int64_t> jobs_;
  bool stopping_ = false;
  std::thread thread_;
};

}  // namespace camlab::service
