// Whose were the frames a camera skipped? A sequence gap says frames were lost, not why:
// the sensor may have missed them (a dropped frame on the bus, a sensor that cannot keep
// up), or the driver had no empty buffer to fill because camlab held them all, dequeued
// too late or not yet given back. The second is camlab's fault, and a capture report must
// not blame the camera for it.
//
// The rule: a frame skipped at time t (its start of exposure, estimated as the previous
// frame's plus the frame interval for each missing frame) was lost by camlab when, at t,
// at least as many buffers as the driver has were out of its hands: frames delivered
// before t whose buffers were given back (requeued) after t. The driver's buffer count is
// the larger of what was asked for and the distinct buffer indices seen. Without
// monotonic timestamps nothing can be said, and every skipped frame counts as the
// device's.
//
// Thread-compatible (one owner: the frame loop).
#pragma once

#include <cstdint>
#include <deque>
#include <optional>

namespace camlab::capture {

class DropAttribution {
 public:
  explicit DropAttribution(int buffers_requested);

  struct Skipped {
    int by_device = 0;
    int by_camlab = 0;  // lost while every buffer was out of the driver
  };
  // A frame was delivered (before it is given back). `interval_ns`: the stream's frame
  // interval when known (0: measured from the timestamps). Returns the frames skipped
  // since the previous one, by whom.
  Skipped on_frame(uint64_t sequence, int64_t timestamp_ns, bool monotonic, int buffer_index,
                   int64_t interval_ns);
  // The frame last delivered was given back to the driver at `now_ns` (CLOCK_MONOTONIC).
  void on_requeue(int64_t now_ns);

  int driver_buffers() const;

 private:
  int64_t interval_ns(int64_t hint_ns) const;

  int buffers_requested_;
  uint64_t indices_seen_ = 0;  // bit i: buffer index i delivered (indices below 64)
  std::optional<uint64_t> last_sequence_;
  std::optional<int64_t> last_timestamp_ns_;  // of the last frame, when monotonic
  std::deque<int64_t> spacings_ns_;           // between consecutive frames, the latest few
  std::deque<int64_t> requeued_ns_;           // when each of the latest frames went back
};

}  // namespace camlab::capture
