#include "service/jobs/live_preview.h"

#include <algorithm>

namespace camlab::service {

namespace {

// Short dequeue waits, so that a job or a stop request is seen within this long.
constexpr std::chrono::milliseconds kPollSlice{100};
constexpr int kPreviewBuffers = 4;

}  // namespace

Result<device::StreamFormat> preview_format(const std::vector<device::ControlInfo>& controls,
                                            const std::vector<device::PixelFormatInfo>& formats,
                                            const capture::CameraTraits& traits) {
  auto plan = capture::plan_capture({{"kind", "single"}}, controls, formats, traits);
  if (!plan) return plan.error();
  return plan->format;
}

Status run_live_preview(device::Camera& camera, const device::StreamFormat& format, LiveFeed& feed,
                        const std::function<bool()>& keep_going,
                        const std::function<void()>& between_frames,
                        std::chrono::milliseconds frame_timeout) {
  auto configured = camera.configure(format);
  if (!configured) return configured.error();
  if (Status started = camera.start(kPreviewBuffers); !started) return started;
  Status outcome;
  auto last_frame = std::chrono::steady_clock::now();
  while (keep_going()) {
    auto frame = camera.dequeue(std::min(kPollSlice, frame_timeout));
    if (!frame) {
      if (frame.error().code != ErrorCode::kTimeout) {
        outcome = frame.error();
        break;
      }
      if (std::chrono::steady_clock::now() - last_frame > frame_timeout) {
        outcome = make_error("timeout", camera.identity().path + ": no preview frame within " +
                                            std::to_string(frame_timeout.count()) + " ms");
        break;
      }
    } else {
      last_frame = std::chrono::steady_clock::now();
      feed.offer(*frame, *configured);
      if (Status requeued = camera.requeue(*frame); !requeued) {
        outcome = requeued;
        break;
      }
    }
    between_frames();
  }
  if (Status stopped = camera.stop(); !stopped && outcome.ok()) outcome = stopped;
  return outcome;
}

}  // namespace camlab::service
