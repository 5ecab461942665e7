// A Camera with an exact, scripted sensor for testing the runner's frame accounting:
// frames start when the runner asks for one (and `frames_ahead` more are already exposing,
// as on a sensor whose next exposure starts during readout), a control written while
// frame n is the next to start is in effect from frame n + latency, SOE timestamps are
// CLOCK_MONOTONIC, and chosen sequence numbers can be dropped or flagged. Each frame is a
// small GREY image whose every pixel is the exposure_time_absolute in effect (mod 256),
// so a test reads the truth from the pixels. With `report_exposure` each frame's metadata
// also reports the exposure in effect (exposure_us), as libcamera pipelines that report
// ExposureTime do.
#pragma once

#include <time.h>

#include <deque>
#include <functional>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "device/camera.h"

namespace camlab::testing {

class ScriptedCamera final : public device::Camera {
 public:
  ScriptedCamera(int latency_frames, int frames_ahead)
      : latency_(latency_frames), ahead_(frames_ahead) {
    identity_ = {"scripted:0", "scripted", "", "scripted camera", "scripted", "none"};
    add("exposure_time_absolute", 1, 200, 10);
    add("gain", 100, 1600, 100);
    device::ControlInfo mode;
    mode.name = "auto_exposure";
    mode.type = device::ControlType::kMenu;
    mode.minimum = 1;
    mode.maximum = 3;
    mode.menu = {{1, "Manual Mode"}, {3, "Aperture Priority Mode"}};
    mode.current = 3;
    controls_.push_back(mode);
    in_effect_ = values();
  }

  std::set<uint64_t> drop_sequences;   // started but never delivered
  std::set<uint64_t> error_sequences;  // delivered with V4L2_BUF_FLAG_ERROR
  std::string clock = "monotonic";
  bool report_exposure = false;
  int fail_set_after = -1;  // set_control calls that succeed before "no_device"
  std::function<void(uint64_t sequence)> on_dequeue;  // called with each frame delivered
  int set_calls = 0;

  const device::CameraIdentity& identity() const override { return identity_; }
  Result<std::vector<device::PixelFormatInfo>> formats() override {
    return std::vector<device::PixelFormatInfo>{{"GREY", "8-bit", {{8, 4, {{1, 100}}}}}};
  }
  Result<std::vector<device::ControlInfo>> controls() override { return controls_; }
  Result<int64_t> get_control(const std::string& name) override {
    for (const auto& c : controls_)
      if (c.name == name) return c.current;
    return make_error("unknown_control", name);
  }
  Result<int64_t> set_control(const std::string& name, int64_t value) override {
    if (fail_set_after >= 0 && set_calls >= fail_set_after) return make_error("no_device", "gone");
    ++set_calls;
    for (auto& c : controls_) {
      if (c.name != name) continue;
      if (name == "exposure_time_absolute") set_now("auto_exposure", 1);  // as V4l2Camera does
      c.current = value;
      if (streaming_)
        pending_.push_back({next_sequence_ + static_cast<uint64_t>(latency_), name, value});
      else
        in_effect_[name] = value;
      return value;
    }
    return make_error("unknown_control", name);
  }
  Result<device::StreamFormat> configure(const device::StreamFormat& requested) override {
    format_ = requested;
    format_.bytes_per_line = requested.width;
    format_.size_bytes = requested.width * requested.height;
    return format_;
  }
  Status start(int) override {
    streaming_ = true;
    return {};
  }
  Status stop() override {
    streaming_ = false;
    for (const auto& p : pending_) in_effect_[p.name] = p.value;
    pending_.clear();
    return {};
  }
  Result<device::Frame> dequeue(std::chrono::milliseconds) override {
    for (;;) {
      while (static_cast<int>(started_.size()) < 1 + ahead_) start_frame();
      Started s = started_.front();
      started_.pop_front();
      if (drop_sequences.count(s.sequence)) continue;
      device::Frame frame;
      frame.meta.sequence = s.sequence;
      frame.meta.timestamp_ns = s.timestamp_ns;
      frame.meta.clock = clock;
      frame.meta.error = error_sequences.count(s.sequence) > 0;
      if (report_exposure) frame.meta.exposure_us = s.exposure * 100;
      buffer_.assign(static_cast<size_t>(format_.width) * format_.height,
                     static_cast<uint8_t>(s.exposure & 0xff));
      frame.data = buffer_.data();
      frame.size = buffer_.size();
      frame.buffer_index = 0;
      ++frames_delivered;
      if (on_dequeue) on_dequeue(s.sequence);
      return frame;
    }
  }
  Status requeue(const device::Frame&) override { return {}; }

  uint64_t next_sequence() const { return next_sequence_; }
  int frames_delivered = 0;

 private:
  struct Pending {
    uint64_t apply_at;
    std::string name;
    int64_t value;
  };
  struct Started {
    uint64_t sequence;
    int64_t timestamp_ns;
    int64_t exposure;
  };

  void add(const std::string& name, int64_t min, int64_t max, int64_t current) {
    device::ControlInfo c;
    c.name = name;
    c.minimum = min;
    c.maximum = max;
    c.current = current;
    c.default_value = current;
    controls_.push_back(c);
  }
  void set_now(const std::string& name, int64_t value) {
    for (auto& c : controls_)
      if (c.name == name) c.current = value;
  }
  std::map<std::string, int64_t> values() const {
    std::map<std::string, int64_t> v;
    for (const auto& c : controls_) v[c.name] = c.current;
    return v;
  }
  static int64_t now_ns() {
    timespec t{};
    clock_gettime(CLOCK_MONOTONIC, &t);
    return static_cast<int64_t>(t.tv_sec) * 1'000'000'000 + t.tv_nsec;
  }
  void start_frame() {
    const uint64_t sequence = next_sequence_++;
    for (auto it = pending_.begin(); it != pending_.end();) {
      if (it->apply_at <= sequence) {
        in_effect_[it->name] = it->value;
        it = pending_.erase(it);
      } else {
        ++it;
      }
    }
    started_.push_back({sequence, now_ns(), in_effect_["exposure_time_absolute"]});
  }

  int latency_;
  int ahead_;
  device::CameraIdentity identity_;
  std::vector<device::ControlInfo> controls_;
  std::map<std::string, int64_t> in_effect_;
  std::vector<Pending> pending_;
  std::deque<Started> started_;
  device::StreamFormat format_;
  std::vector<uint8_t> buffer_;
  bool streaming_ = false;
  uint64_t next_sequence_ = 0;
};

}  // namespace camlab::testing
