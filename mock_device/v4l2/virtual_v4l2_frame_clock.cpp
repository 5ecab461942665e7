#include "mock_device/v4l2/virtual_v4l2_frame_clock.h"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace camlab::mock {

namespace {

// The fraction for one interval. Specs (and UVC descriptors) give intervals in whole
// microseconds, so 1/30 s comes as 33333 us: an interval within half a microsecond of a
// whole rate's, or of an NTSC rate's, is that rate.
v4l2_fract one_interval_fraction(double interval_us) {
  const double fps = 1e6 / interval_us;
  const double whole = std::round(fps);
  if (whole >= 1 && std::fabs(interval_us - 1e6 / whole) <= 0.5)
    return {1, static_cast<uint32_t>(whole)};
  const double ntsc = std::round(fps * 1.001);
  if (ntsc >= 1 && std::fabs(interval_us - 1.001e6 / ntsc) <= 0.5)
    return {1001, static_cast<uint32_t>(ntsc) * 1000};
  const auto us = static_cast<uint32_t>(std::max(1L, std::lround(interval_us)));
  return {us, 1000000u};
}

}  // namespace

v4l2_fract frame_interval_fraction(double interval_us, uint32_t multiple) {
  const v4l2_fract one = one_interval_fraction(interval_us);
  const uint64_t numerator = static_cast<uint64_t>(one.numerator) * std::max(1u, multiple);
  const uint64_t divisor = std::gcd(numerator, static_cast<uint64_t>(one.denominator));
  return {static_cast<uint32_t>(numerator / divisor),
          static_cast<uint32_t>(one.denominator / divisor)};
}

VirtualV4l2FrameClock::VirtualV4l2FrameClock(double sensor_frame_interval_us, bool realtime)
    : sensor_frame_interval_us_(sensor_frame_interval_us), realtime_(realtime) {
  time_per_frame_ = frame_interval_fraction(sensor_frame_interval_us_);
}

void VirtualV4l2FrameClock::set_time_per_frame(v4l2_fract asked) {
  const double base_s = sensor_frame_interval_us_ * 1e-6;
  const double asked_s =
      asked.denominator ? static_cast<double>(asked.numerator) / asked.denominator : base_s;
  const uint32_t multiple = asked_s > 1.5 * base_s ? 2 : 1;
  time_per_frame_ = frame_interval_fraction(sensor_frame_interval_us_, multiple);
}

std::chrono::microseconds VirtualV4l2FrameClock::interval() const {
  return std::chrono::microseconds(static_cast<int64_t>(
      1e6 * time_per_frame_.numerator / std::max<uint32_t>(time_per_frame_.denominator, 1)));
}

void VirtualV4l2FrameClock::start() {
  next_tick_ = Clock::now();
  if (grid_origin_ && interval().count() > 0) {
    // The first grid tick at or after now (the origin may lie either side of it).
    const auto step = interval();
    int64_t ticks = (next_tick_ - *grid_origin_) / step;  // rounded towards zero
    if (*grid_origin_ + step * ticks < next_tick_) ++ticks;
    next_tick_ = *grid_origin_ + step * ticks;
  }
  origin_ = next_tick_ - interval() * static_cast<int64_t>(next_sequence_);
  running_ = true;
}

VirtualV4l2FrameClock::Clock::time_point VirtualV4l2FrameClock::tick_of(uint64_t sequence) const {
  return origin_ + interval() * static_cast<int64_t>(sequence);
}

int64_t VirtualV4l2FrameClock::grid_tick_index(uint64_t sequence) const {
  const auto step = interval();
  if (!grid_origin_ || !realtime_ || step.count() <= 0) return static_cast<int64_t>(sequence);
  // Rounded: a tick lies on the grid, up to the clock's integer rounding.
  return (tick_of(sequence) - *grid_origin_ + step / 2) / step;
}

uint64_t VirtualV4l2FrameClock::first_unstarted(Clock::time_point now) const {
  if (!realtime_ || !running_ || now < tick_of(next_sequence_)) return next_sequence_;
  const auto step = interval();
  if (step.count() <= 0) return next_sequence_;
  const auto since_origin = now - origin_;
  return static_cast<uint64_t>(since_origin / step) + 1;
}

void VirtualV4l2FrameClock::advance() {
  const auto step = interval();
  next_tick_ += step;
  // A frame that took longer than the interval to render costs ticks, as a sensor that
  // cannot keep up would: the skipped ticks show as sequence gaps.
  while (next_tick_ + step < Clock::now()) {
    next_tick_ += step;
    ++next_sequence_;
  }
}

bool VirtualV4l2FrameClock::take_drop() {
  if (drop_frames_ <= 0) return false;
  --drop_frames_;
  return true;
}

}  // namespace camlab::mock
