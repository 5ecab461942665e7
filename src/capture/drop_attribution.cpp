#include "capture/drop_attribution.h"

#include <algorithm>
#include <bit>
#include <vector>

namespace camlab::capture {

namespace {

constexpr size_t kSpacingsKept = 15;
// More than any driver's buffers: older frames went back long before.
constexpr size_t kRequeuesKept = 64;
// A gap longer than this is judged on its first frames only; the rest are the device's.
constexpr uint64_t kMaxFramesJudged = 4096;

}  // namespace

DropAttribution::DropAttribution(int buffers_requested)
    : buffers_requested_(std::max(buffers_requested, 1)) {}

int DropAttribution::driver_buffers() const {
  return std::max(buffers_requested_, std::popcount(indices_seen_));
}

int64_t DropAttribution::interval_ns(int64_t hint_ns) const {
  if (hint_ns > 0) return hint_ns;
  if (spacings_ns_.empty()) return 0;
  std::vector<int64_t> sorted(spacings_ns_.begin(), spacings_ns_.end());
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(sorted.size() / 2),
                   sorted.end());
  return sorted[sorted.size() / 2];
}

DropAttribution::Skipped DropAttribution::on_frame(uint64_t sequence, int64_t timestamp_ns,
                                                   bool monotonic, int buffer_index,
                                                   int64_t interval_hint_ns) {
  Skipped skipped;
  if (buffer_index >= 0 && buffer_index < 64) indices_seen_ |= uint64_t{1} << buffer_index;
  if (last_sequence_ && sequence > *last_sequence_ + 1) {
    const uint64_t missing = sequence - *last_sequence_ - 1;
    const int64_t interval = interval_ns(interval_hint_ns);
    if (monotonic && last_timestamp_ns_ && interval > 0) {
      const int buffers = driver_buffers();
      // requeued_ns_ is in order, so the buffers still out at t are those given back
      // after t; as t grows there are fewer, and the frames camlab lost are the first of
      // the gap.
      for (uint64_t k = 1; k <= std::min(missing, kMaxFramesJudged); ++k) {
        const int64_t t = *last_timestamp_ns_ + static_cast<int64_t>(k) * interval;
        const auto out =
            requeued_ns_.end() - std::upper_bound(requeued_ns_.begin(), requeued_ns_.end(), t);
        if (out < buffers) break;
        ++skipped.by_camlab;
      }
    }
    skipped.by_device = static_cast<int>(std::min<uint64_t>(missing, 1u << 20)) - skipped.by_camlab;
  }
  if (monotonic) {
    if (last_timestamp_ns_ && last_sequence_ && sequence == *last_sequence_ + 1 &&
        timestamp_ns > *last_timestamp_ns_) {
      spacings_ns_.push_back(timestamp_ns - *last_timestamp_ns_);
      if (spacings_ns_.size() > kSpacingsKept) spacings_ns_.pop_front();
    }
    last_timestamp_ns_ = timestamp_ns;
  } else {
    last_timestamp_ns_.reset();
  }
  last_sequence_ = sequence;
  return skipped;
}

void DropAttribution::on_requeue(int64_t now_ns) {
  requeued_ns_.push_back(now_ns);
  if (requeued_ns_.size() > kRequeuesKept) requeued_ns_.pop_front();
}

}  // namespace camlab::capture
