// What a camera's worker does for a capture job and a latency-probe job: plan against the
// camera's current controls, find the control latency (stored per device, probed on
// first use), run the capture into DATA/captures/job-NNNNNN with progress written to the
// job store, and turn the run's summary into the job's final state.
//
// Thread-bound: called on the camera's worker thread, which owns `camera`.
#pragma once

#include <atomic>
#include <chrono>
#include <filesystem>
#include <optional>

#include <nlohmann/json.hpp>

#include "base/result.h"
#include "capture/capture_plan.h"
#include "capture/frame_tap.h"
#include "device/camera.h"
#include "service/store/job_store.h"

namespace camlab::service {

class Metrics;

// Used when neither a probe nor a specification gives the latency: the top of the range
// sensors take (2-6 frames), so no frame is kept too early.
inline constexpr int kFallbackLatencyFrames = 6;

struct JobOutcome {
  JobState state = JobState::kFailed;
  std::optional<Error> error;
  nlohmann::json result;
  bool device_failed = false;  // the camera errored: the worker reopens it before the next job
  std::string failure_detail;  // the device's own words for a failure, without the summary
};

struct CaptureJobEnv {
  JobStore& store;
  Metrics& metrics;
  std::filesystem::path data_dir;
  std::optional<int> spec_latency_frames;
  capture::CameraTraits traits;
  nlohmann::json source;  // camera description for the manifest
  std::chrono::milliseconds frame_timeout{5000};
  const std::atomic<bool>* cancel = nullptr;         // user cancel or shutdown
  const std::atomic<bool>* shutting_down = nullptr;  // a cancel from shutdown ends "interrupted"
  capture::FrameTap* frame_tap = nullptr;            // the live view's feed; may be null
  // What the camera's worker did last before this job and when it ended (realtime, ms
  // since the epoch; 0: nothing yet), so that a synchronised start missed says why.
  std::string previous_work;
  int64_t previous_work_ended_unix_ms = 0;
};

JobOutcome execute_capture(device::Camera& camera, const JobRecord& job, const CaptureJobEnv& env);
JobOutcome execute_latency_probe(device::Camera& camera, const JobRecord& job,
                                 const CaptureJobEnv& env);

// Probes the camera's control latency and stores it (or the spec's, when the probe is
// inconclusive) as a capture would before its first frame; `frames_consumed` counts the
// probe's frames, whether it succeeded or not. Errors: device errors, "cancelled".
Status probe_and_store_latency(device::Camera& camera, const CaptureJobEnv& env,
                               int* frames_consumed);

// Whether an error code means the device itself failed (as opposed to bad input).
bool is_device_error(ErrorCode code);

}  // namespace camlab::service
