// One camera's frames for the people looking at it (the dashboard's live view, its
// histogram): the camera's worker offers frames as it dequeues them, during a capture job
// (through capture::FrameTap) or in its idle preview loop, and the feed copies one only
// when a viewer will want it, at most twice as often as the fastest viewer's frame-rate
// cap, so a capture pays one copy per viewed frame and nothing when nobody looks.
//
// Demand runs the other way: the worker previews (streams with no job) only while the
// feed is wanted, i.e. while a viewer is open or a one-off request (a histogram) asked
// within the last few seconds.
//
// Owned by the camera's worker through shared_ptr, shared with the live hub and open
// viewers; close() (the camera is gone, or the daemon stops) ends every viewer.
// Thread-safe; offer() is called on the worker thread and returns after a copy at most.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "base/result.h"
#include "capture/capture_plan.h"
#include "capture/frame_convert.h"
#include "capture/frame_tap.h"
#include "device/camera.h"

namespace camlab::service {

// A frame as the driver delivered it, copied out of its buffer.
struct LiveFrame {
  std::vector<uint8_t> bytes;
  device::StreamFormat format;
  device::FrameMetadata meta;
  int sensor_bit_depth = 0;  // the camera's traits, to read the DN (0: unknown)
  int black_level_dn = 0;
  bool isp_subtracts_black = false;
  int64_t received_ns = 0;  // CLOCK_MONOTONIC when offered
  uint64_t generation = 0;  // 1, 2, ... in the order offered
};

class LiveFeed : public capture::FrameTap {
 public:
  // A one-off request keeps the feed wanted this long (a histogram polled every second
  // keeps the preview running; an abandoned page stops it soon).
  static constexpr std::chrono::milliseconds kWantedAfterRequest{3000};
  // Frames are copied at most this often, whatever the viewers ask.
  static constexpr double kMaxCopiesPerSecond = 60;

  LiveFeed(std::string camera_id, capture::CameraTraits traits);

  const std::string& camera_id() const { return camera_id_; }

  // capture::FrameTap: copies `frame` if someone wants it now.
  void offer(const device::Frame& frame, const device::StreamFormat& format) override;

  // Viewers (each with its frame-rate cap); the feed is wanted while one is open.
  void add_viewer(double fps_cap);
  void remove_viewer(double fps_cap);
  int viewers() const;
  // A one-off request: wanted for kWantedAfterRequest from now.
  void touch();
  bool wanted() const;

  // The newest frame copied, or null.
  std::shared_ptr<const LiveFrame> latest() const;

  // Called (outside the feed's lock) after each copy: the hub wakes its thread.
  void set_frame_listener(std::function<void()> listener);
  // Called (outside the feed's lock) when the feed becomes wanted: the worker wakes to
  // preview.
  void set_demand_listener(std::function<void()> listener);

  // The camera is gone or the daemon stops: no more frames; viewers end.
  void close();
  bool closed() const { return closed_.load(); }

 private:
  double fastest_cap_locked() const;

  const std::string camera_id_;
  const capture::CameraTraits traits_;
  mutable std::mutex mutex_;
  std::vector<double> viewer_caps_;
  int64_t wanted_until_ns_ = 0;
  int64_t last_copy_ns_ = 0;
  uint64_t generation_ = 0;
  std::shared_ptr<const LiveFrame> latest_;
  std::function<void()> frame_listener_;
  std::function<void()> demand_listener_;
  std::atomic<bool> closed_{false};
};

int64_t monotonic_now_ns();

// The frame as a capture would store it (capture/frame_convert.h): DN of the sensor's depth,
// the layout, the levels.
Result<capture::ConvertedFrame> convert_live_frame(const LiveFrame& frame);

}  // namespace camlab::service
