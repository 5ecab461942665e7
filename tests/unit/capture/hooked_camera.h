// A camera as its client sees it, with hooks at the moments a loaded machine stretches:
// `before_dequeue(n)` runs before the client's n-th dequeue (1, 2, ...: a stall there is
// the loop descheduled or stuck), `after_set_control(name, value, n)` after the n-th write of
// that control returned and before the client sees it return (the client's thread preempted
// between the ioctl and its next clock read). Everything else goes to the real camera.
#pragma once

#include <functional>
#include <map>
#include <string>
#include <utility>

#include "device/camera.h"

namespace camlab::testing {

class HookedCamera final : public device::Camera {
 public:
  using DequeueHook = std::function<void(int)>;
  using SetControlHook = std::function<void(const std::string&, int64_t, int)>;

  HookedCamera(device::Camera& inner, DequeueHook before_dequeue,
               SetControlHook after_set_control = {})
      : inner_(inner),
        before_dequeue_(std::move(before_dequeue)),
        after_set_control_(std::move(after_set_control)) {}

  const device::CameraIdentity& identity() const override { return inner_.identity(); }
  Result<std::vector<device::PixelFormatInfo>> formats() override { return inner_.formats(); }
  Result<std::vector<device::ControlInfo>> controls() override { return inner_.controls(); }
  Result<int64_t> get_control(const std::string& n) override { return inner_.get_control(n); }
  Result<int64_t> set_control(const std::string& n, int64_t v) override {
    auto applied = inner_.set_control(n, v);
    if (after_set_control_) after_set_control_(n, v, ++writes_[n]);
    return applied;
  }
  Result<device::StreamFormat> configure(const device::StreamFormat& f) override {
    return inner_.configure(f);
  }
  Status start(int buffers) override { return inner_.start(buffers); }
  Status stop() override { return inner_.stop(); }
  Result<device::Frame> dequeue(std::chrono::milliseconds timeout) override {
    if (before_dequeue_) before_dequeue_(++dequeues_);
    return inner_.dequeue(timeout);
  }
  Status requeue(const device::Frame& frame) override { return inner_.requeue(frame); }

 private:
  device::Camera& inner_;
  DequeueHook before_dequeue_;
  SetControlHook after_set_control_;
  int dequeues_ = 0;
  std::map<std::string, int> writes_;
};

}  // namespace camlab::testing
