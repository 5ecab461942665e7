// A camera's idle preview: while someone looks at the live view and no job runs, the
// camera's worker streams it in the format a capture would use by default and offers each
// frame to the camera's live feed (service/live/live_feed.h). Controls may change between
// frames (the dashboard's exposure slider): V4L2 and libcamera take them while streaming.
//
// Thread-bound: runs on the camera's worker thread, which owns the camera.
#pragma once

#include <chrono>
#include <functional>

#include "base/result.h"
#include "capture/capture_plan.h"
#include "device/camera.h"
#include "service/live/live_feed.h"

namespace camlab::service {

// The format a capture request without one would get (capture/capture_plan.h).
Result<device::StreamFormat> preview_format(const std::vector<device::ControlInfo>& controls,
                                            const std::vector<device::PixelFormatInfo>& formats,
                                            const capture::CameraTraits& traits);

// Streams until `keep_going()` is false, calling `between_frames()` after each frame (the
// worker runs its queued control changes there). No frame for `frame_timeout` is a
// "timeout" error; device errors end it with their code. The stream is stopped on return.
Status run_live_preview(device::Camera& camera, const device::StreamFormat& format, LiveFeed& feed,
                        const std::function<bool()>& keep_going,
                        const std::function<void()>& between_frames,
                        std::chrono::milliseconds frame_timeout);

}  // namespace camlab::service
