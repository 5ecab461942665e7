#include "capture/settle_tracker.h"

#include <algorithm>

namespace camlab::capture {

SettleTracker::SettleTracker(int latency_max_frames, int latency_min_frames)
    : latency_max_(std::max(0, latency_max_frames)),
      latency_min_(std::clamp(latency_min_frames, 0, std::max(0, latency_max_frames))) {}

int SettleTracker::on_change(int64_t began_ns, int64_t written_ns, int buffers_in_driver) {
  changes_.push_back({std::min(began_ns, written_ns), written_ns, std::max(0, buffers_in_driver), 0,
                      last_sequence_, std::nullopt, false});
  return static_cast<int>(changes_.size()) - 1;
}

int SettleTracker::on_frame(uint64_t sequence, int64_t soe_timestamp_ns, bool timestamp_monotonic) {
  // Changes are written in time order, so they learn their first frame in order.
  for (size_t i = first_unidentified_; i < changes_.size(); ++i) {
    Change& c = changes_[i];
    if (c.first_frame) continue;
    const bool after = timestamp_monotonic ? soe_timestamp_ns > c.written_ns
                                           : ++c.dequeued_since > c.buffers_in_driver;
    if (after)
      c.first_frame = sequence;
    else if (timestamp_monotonic && soe_timestamp_ns < c.began_ns)
      c.last_before = sequence;  // surely started before the write
    else if (timestamp_monotonic)
      c.straddled = true;  // started while the write was under way: n or the frame before it
  }
  last_sequence_ = sequence;
  while (first_unidentified_ < changes_.size() && changes_[first_unidentified_].first_frame)
    ++first_unidentified_;

  // The newest change that has surely arrived by this frame...
  for (size_t i = first_unidentified_; i-- > 0;) {
    const uint64_t arrives = *changes_[i].first_frame + static_cast<uint64_t>(latency_max_);
    if (sequence < arrives) continue;
    // ...unless its successor may have arrived too (the settling gap between them). An
    // unidentified successor's n_lo is already past this frame with timestamps.
    if (i + 1 < changes_.size() &&
        sequence >= changes_[i + 1].n_lo() + static_cast<uint64_t>(latency_min_))
      return -1;
    return static_cast<int>(i);
  }
  return -1;
}

std::optional<uint64_t> SettleTracker::first_frame_after(int change) const {
  if (change < 0 || change >= change_count()) return std::nullopt;
  return changes_[static_cast<size_t>(change)].first_frame;
}

bool SettleTracker::frame_started_during_write(int change) const {
  return change >= 0 && change < change_count() && changes_[static_cast<size_t>(change)].straddled;
}

std::optional<int> SettleTracker::frames_secured_after(int change, uint64_t last_sequence) const {
  const auto n = first_frame_after(change);
  if (!n) return std::nullopt;
  // A write now is seen first by frame last_sequence + 1 or later, which keeps change's
  // settings up to last_sequence + L_min at least.
  const uint64_t first = std::max(last_sequence + 1, *n + static_cast<uint64_t>(latency_max_));
  const uint64_t last = last_sequence + static_cast<uint64_t>(latency_min_);
  return last >= first ? static_cast<int>(last - first + 1) : 0;
}

bool SettleTracker::window_closed(int change, uint64_t last_sequence) const {
  // n_lo is final once the next change has found its first frame.
  if (!first_frame_after(change + 1)) return false;
  return last_sequence + 1 >=
         changes_[static_cast<size_t>(change) + 1].n_lo() + static_cast<uint64_t>(latency_min_);
}

}  // namespace camlab::capture
