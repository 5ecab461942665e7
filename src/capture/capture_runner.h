// Runs a capture plan on a camera with frame-accurate settings: after controls change,
// a frame is kept only once the new values are in effect, i.e. from the frame that
// started (V4L2 start-of-exposure timestamp) after the change plus the camera's control
// latency in frames. Everything before is discarded and counted in the next kept frame's
// sidecar (frames_discarded). Each kept frame is written to a capture folder
// (image/capture_folder.h) with the settings in effect read back from the camera.
//
// The rule, in sequence numbers (capture/settle_tracker.h has the reasoning): a change
// written after frame q was dequeued is first seen by frame n > q (the first whose SOE
// timestamp is later than the write); with latency L it is in effect for frames
// [n_i + L, n_(i+1) + L). So the next step's controls are written as soon as the frames
// the current step still needs are among the L frames after the last one dequeued: the
// stream never restarts, and a bracket of S steps x R repeats consumes S x R + L frames
// when the loop keeps up with the camera. That needs the latency to be exact (from the
// camera spec or the probe); a latency known only as a range gets
// control_latency_min_frames < control_latency_frames and waits longer. Frames lost to
// drops or flagged by the driver are taken again: a step whose window closes short is
// written again later for its missing repeats.
//
// The timestamps must be start-of-exposure (V4L2_BUF_FLAG_TSTAMP_SRC_SOE, as the virtual
// camera and most sensor drivers give); with a non-monotonic clock the runner falls back
// to a bound from the number of buffers (slower, still safe).
//
// Frames are lost two ways, reported apart: the device skips sequence numbers (a sensor
// that cannot keep up, a dropped frame on the bus), or camlab falls behind: the driver
// skips frames while camlab holds all its buffers (capture/drop_attribution.h has the
// rule), or the frame writer's queue is full (a disk slower than the camera) and a frame
// that would have been kept is not. Either way the step is taken again.
//
// Controls the plan changed (and the auto modes a manual value switches off) are restored
// afterwards, on success, failure and cancel. A camera that fails mid-plan (unplugged,
// I/O error, timeout) ends the run with that error, and the frames already written stay
// in the folder (manifest "complete": false). The stream format is set for the run and
// left so.
//
// Thread-bound: runs on the camera's worker thread; the observer is called on it. Frames
// are encoded and written on a helper thread (capture/frame_writer.h).
#pragma once

#include <atomic>
#include <chrono>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>

#include "base/result.h"
#include "capture/capture_plan.h"
#include "capture/frame_tap.h"
#include "capture/frame_writer.h"
#include "device/camera.h"
#include "image/capture_folder.h"

namespace camlab::capture {

struct CaptureProgress {
  int frames_kept = 0;
  int frames_total = 0;
  int frames_discarded = 0;  // so far, over the whole run
};

class CaptureObserver {
 public:
  virtual ~CaptureObserver() = default;
  // After each frame is listed in the folder's journal (image and sidecar synced to disk):
  // in batches, as the frame writer commits them (capture/frame_writer.h).
  virtual void on_frame(const image::CaptureFrameEntry& entry, const image::FrameSidecar& sidecar,
                        const CaptureProgress& progress) = 0;
};

struct CaptureOptions {
  int control_latency_frames = 0;  // the device's (probed or from its spec)
  // The shortest the latency can be, when it is not exact; -1: exact (= the above).
  int control_latency_min_frames = -1;
  int buffer_count = 4;
  std::chrono::milliseconds frame_timeout{2000};
  const std::atomic<bool>* cancel = nullptr;         // checked between frames; may be null
  nlohmann::json source = nlohmann::json::object();  // camera description for the manifest
  FrameWriter::Limits writer_limits;                 // frames waiting for the disk, in memory
  image::CommitPolicy commit_policy;                 // how often frames are synced and listed
  // Offered every frame dequeued, before it is requeued (a live view beside the capture);
  // may be null. Borrowed for the run.
  FrameTap* frame_tap = nullptr;
};

struct CaptureSummary {
  int frames_kept = 0;
  int frames_discarded = 0;  // dequeued but not kept (settling, surplus, flagged by the driver)
  int frames_dropped = 0;    // lost: by the device + by camlab
  int frames_dropped_by_device = 0;  // sequence numbers skipped while the driver had a buffer
  int frames_dropped_by_camlab = 0;  // skipped while camlab held every buffer, or not kept
                                     // because the frame writer had no room
  int frames_refused_by_writer = 0;  // of those, the frames the writer had no room for
  int frames_consumed = 0;           // kept + discarded + dropped
  int frames_minimum = 0;            // what a perfect run takes: total frames + latency
  int steps_retaken = 0;             // steps written again because frames were lost
  double wall_seconds = 0;
  bool cancelled = false;
  std::optional<Error> failure;        // set when the camera failed mid-plan (frames kept stay)
  std::optional<Error> restore_error;  // a control could not be put back (frames are fine)
  std::filesystem::path folder;
  FrameWriter::Stats writer;  // how deep the writer's queue got, and its commits
};

// Creates `folder` (must not exist, or be empty) and runs `plan`. Returns an error only
// when nothing could start (bad options or folder, configure, first controls or start
// failed; controls are restored then too); a failure during the run is reported in
// CaptureSummary::failure with the frames kept so far.
Result<CaptureSummary> run_capture(device::Camera& camera, const CapturePlan& plan,
                                   const std::filesystem::path& folder,
                                   const CaptureOptions& options, CaptureObserver* observer);

}  // namespace camlab::capture
