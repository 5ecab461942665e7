#include "service/live/live_feed.h"

#include <time.h>

#include <algorithm>
#include <cstring>

namespace camlab::service {

int64_t monotonic_now_ns() {
  timespec now{};
  ::clock_gettime(CLOCK_MONOTONIC, &now);
  return static_cast<int64_t>(now.tv_sec) * 1'000'000'000 + now.tv_nsec;
}

Result<capture::ConvertedFrame> convert_live_frame(const LiveFrame& frame) {
  device::Frame raw;
  raw.data = frame.bytes.data();
  raw.size = frame.bytes.size();
  raw.meta = frame.meta;
  return capture::convert_frame(raw, frame.format, frame.sensor_bit_depth, frame.black_level_dn,
                                frame.isp_subtracts_black);
}

LiveFeed::LiveFeed(std::string camera_id, capture::CameraTraits traits)
    : camera_id_(std::move(camera_id)), traits_(std::move(traits)) {}

double LiveFeed::fastest_cap_locked() const {
  double fastest = 0;
  for (double cap : viewer_caps_) fastest = std::max(fastest, cap);
  return fastest;
}

void LiveFeed::offer(const device::Frame& frame, const device::StreamFormat& format) {
  if (closed_.load() || !frame.data || frame.meta.error) return;
  const int64_t now = monotonic_now_ns();
  std::function<void()> listener;
  {
    std::lock_guard lock(mutex_);
    const bool requested = now < wanted_until_ns_;
    if (viewer_caps_.empty() && !requested) return;
    // Twice the fastest cap, so that each viewer's next slot finds a frame newer than its
    // last; a one-off request alone is served at 10 frames/s.
    const double copies_per_s =
        std::min(kMaxCopiesPerSecond, std::max(2 * fastest_cap_locked(), 10.0));
    if (now - last_copy_ns_ < static_cast<int64_t>(1e9 / copies_per_s)) return;
    last_copy_ns_ = now;
    listener = frame_listener_;
  }
  auto copy = std::make_shared<LiveFrame>();
  const size_t used =
      frame.meta.bytes_used ? std::min<size_t>(frame.meta.bytes_used, frame.size) : frame.size;
  copy->bytes.assign(frame.data, frame.data + used);
  copy->format = format;
  copy->meta = frame.meta;
  copy->sensor_bit_depth = traits_.sensor_bit_depth;
  copy->black_level_dn = traits_.black_level_dn;
  copy->isp_subtracts_black = traits_.isp_subtracts_black;
  copy->received_ns = now;
  {
    std::lock_guard lock(mutex_);
    copy->generation = ++generation_;
    latest_ = std::move(copy);
  }
  if (listener) listener();
}

void LiveFeed::add_viewer(double fps_cap) {
  std::function<void()> listener;
  {
    std::lock_guard lock(mutex_);
    viewer_caps_.push_back(fps_cap);
    listener = demand_listener_;
  }
  if (listener) listener();
}

void LiveFeed::remove_viewer(double fps_cap) {
  std::lock_guard lock(mutex_);
  if (auto it = std::find(viewer_caps_.begin(), viewer_caps_.end(), fps_cap);
      it != viewer_caps_.end())
    viewer_caps_.erase(it);
}

int LiveFeed::viewers() const {
  std::lock_guard lock(mutex_);
  return static_cast<int>(viewer_caps_.size());
}

void LiveFeed::touch() {
  std::function<void()> listener;
  {
    std::lock_guard lock(mutex_);
    const bool was_wanted = !viewer_caps_.empty() || monotonic_now_ns() < wanted_until_ns_;
    wanted_until_ns_ =
        monotonic_now_ns() +
        std::chrono::duration_cast<std::chrono::nanoseconds>(kWantedAfterRequest).count();
    if (!was_wanted) listener = demand_listener_;
  }
  if (listener) listener();
}

bool LiveFeed::wanted() const {
  if (closed_.load()) return false;
  std::lock_guard lock(mutex_);
  return !viewer_caps_.empty() || monotonic_now_ns() < wanted_until_ns_;
}

std::shared_ptr<const LiveFrame> LiveFeed::latest() const {
  std::lock_guard lock(mutex_);
  return latest_;
}

void LiveFeed::set_frame_listener(std::function<void()> listener) {
  std::lock_guard lock(mutex_);
  frame_listener_ = std::move(listener);
}

void LiveFeed::set_demand_listener(std::function<void()> listener) {
  std::lock_guard lock(mutex_);
  demand_listener_ = std::move(listener);
}

void LiveFeed::close() {
  std::function<void()> listener;
  {
    std::lock_guard lock(mutex_);
    if (closed_.exchange(true)) return;
    listener = frame_listener_;
  }
  if (listener) listener();  // the hub ends the viewers waiting
}

}  // namespace camlab::service
