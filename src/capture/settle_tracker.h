// Which frames carry which control settings: the bookkeeping behind frame-accurate
// capture, kept apart from any camera so that it can be tested on made-up streams.
//
// The model (V4L2, and the virtual camera exactly): a control written while frame n is
// the next to start is in effect from frame n + L on, L the control latency in frames.
// n is found from start-of-exposure (SOE) timestamps, against two CLOCK_MONOTONIC times:
// one read before the write began, one after it (and its read-back) returned. A frame that
// started in between may be n or the frame before it (the device took the value at some
// moment of the call, and the caller's thread may have been preempted on either side), so
// n is kept as a range: n_hi, the first frame seen that started after the write returned,
// and n_lo, one past the last frame seen that started before it began. Dropped frames
// (sequence gaps) widen the range the same way. A new window opens with n_hi (never
// early) and the previous one closes with n_lo (never late).
//
// Without usable timestamps (clock not monotonic), every buffer the driver held at the
// write may hold a frame that started before it, so n_hi is the first frame dequeued
// after those, and n_lo one past the last frame dequeued before the write.
//
// A latency known only as a range [L_min, L_max] (L_min = L_max when exact) gives change
// i the frames [n_hi_i + L_max, n_lo_(i+1) + L_min): from the latest it can have arrived
// until the earliest the next one can. Frames outside every window are settling frames.
//
// Writing early: when q is the last frame dequeued (so it has started), a write now gets
// n_lo_(i+1) >= q + 1, so the frames q+1 .. q+L_min that are also >= n_i + L_max still carry
// change i. The runner writes change i+1 as soon as those, with the frames kept so far,
// are all change i still needs: with an exact latency L and one frame per step that is
// right after frame n_i arrives, so a 9-step bracket takes 9 + L frames, not 9 (L + 1).
// With L_min = 0 it reduces to "after the last needed frame has started".
//
// Thread-compatible (one owner).
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

namespace camlab::capture {

class SettleTracker {
 public:
  // 0 <= latency_min_frames <= latency_max_frames (clamped into that order).
  SettleTracker(int latency_max_frames, int latency_min_frames);

  // A change was written: `began_ns` is CLOCK_MONOTONIC read before the first write of it
  // began, `written_ns` after the last returned. `buffers_in_driver`: buffers the driver
  // held then (queued, filling or done and not yet dequeued), for the bound without
  // timestamps; 0 before streaming starts. Returns the change's index (0, 1, ...).
  int on_change(int64_t began_ns, int64_t written_ns, int buffers_in_driver);
  // A change whose moment is known exactly (a request's controls, made-up streams).
  int on_change(int64_t written_ns, int buffers_in_driver) {
    return on_change(written_ns, written_ns, buffers_in_driver);
  }

  // A dequeued frame, in dequeue order. Returns the change whose settings are surely in
  // effect for it, or -1 while settings settle (or before any change).
  int on_frame(uint64_t sequence, int64_t soe_timestamp_ns, bool timestamp_monotonic);

  // n_hi of change i: the first frame seen that started after it, once known.
  std::optional<uint64_t> first_frame_after(int change) const;

  // Whether a frame seen started while change i was being written (timestamps only): n is
  // then that frame or the one after it, a count from n_hi may be one short.
  bool frame_started_during_write(int change) const;

  // Frames after `last_sequence` that would still carry `change` if the next change were
  // written now (none dropped); nullopt while n_change is unknown.
  std::optional<int> frames_secured_after(int change, uint64_t last_sequence) const;

  // True when no frame after `last_sequence` can carry `change` any more (the next change
  // has arrived).
  bool window_closed(int change, uint64_t last_sequence) const;

  int change_count() const { return static_cast<int>(changes_.size()); }
  int latency_max_frames() const { return latency_max_; }
  int latency_min_frames() const { return latency_min_; }

 private:
  struct Change {
    int64_t began_ns = 0;
    int64_t written_ns = 0;
    int buffers_in_driver = 0;
    int dequeued_since = 0;
    std::optional<uint64_t> last_before;  // the last frame seen that surely started before it
    std::optional<uint64_t> first_frame;  // n_hi
    bool straddled = false;               // a frame started between began_ns and written_ns
    uint64_t n_lo() const { return last_before ? *last_before + 1 : 0; }
  };

  int latency_max_;
  int latency_min_;
  std::optional<uint64_t> last_sequence_;
  std::vector<Change> changes_;
  size_t first_unidentified_ = 0;  // changes before it all know n
};

}  // namespace camlab::capture
