// The control-latency probe: measures how many frames a new exposure takes to show, by
// stepping exposure_time_absolute (by a factor the signal can resolve without clipping)
// and watching the mean signal frame by frame. The latency is the number of frames from
// the first frame that started after the change to the first frame whose mean signal
// reached the new level (midway between the two plateaus). Repeated over several steps
// (up and down); the result is the most frequent value, and is only reported when the
// repetitions agree (a strict majority of them). A step whose frames were dropped or
// flagged around the change, or whose frame started while the write was under way (then
// the device may count it as the first after the change, the probe cannot), is measured
// again.
//
// It streams the smallest size of the camera's deepest greyscale format (the mean signal
// needs no resolution) and leaves that format set; a capture configures its own.
//
// Thread-bound (the camera's worker thread). Restores the exposure it changed and the
// auto-exposure mode that writing a manual exposure switched off.
#pragma once

#include <atomic>
#include <vector>

#include "base/result.h"
#include "device/camera.h"

namespace camlab::capture {

struct LatencyProbeResult {
  int latency_frames = 0;
  int repetitions = 0;  // steps measured
  int agreeing = 0;     // steps that gave latency_frames
  // The mean signal of every frame seen, in order, in the streamed format's units (Y16:
  // the 16-bit values; GREY/YUYV: 8-bit); NaN for a frame the driver flagged.
  std::vector<double> mean_dn_trace;
  int frames_consumed = 0;
};

// Errors: "unsupported" (no exposure control), "inconclusive" (the signal does not
// change with exposure, e.g. a dark scene, or the repetitions disagree), "cancelled" when
// `cancel` (checked every 100 ms while waiting for a frame, and between frames) is set,
// device errors. `frames_consumed`, when given, is set to the frames the probe took from
// the camera whether it succeeded or not (a failed probe costs frames too).
Result<LatencyProbeResult> probe_control_latency(device::Camera& camera, int repetitions = 3,
                                                 int max_latency_frames = 8,
                                                 const std::atomic<bool>* cancel = nullptr,
                                                 int* frames_consumed = nullptr);

}  // namespace camlab::capture
