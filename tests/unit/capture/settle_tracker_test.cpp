// The frame-accounting rule on made-up streams: which frame carries which change, with
// exact and uncertain latencies, dropped frames, and without timestamps.
#include "capture/settle_tracker.h"

#include <gtest/gtest.h>

namespace camlab::capture {
namespace {

// Frame s starts at 10 s + 10 (ns, made up); a change written at t sees its first frame
// at the first s with 10 s + 10 > t.
int64_t start_ns(uint64_t sequence) { return static_cast<int64_t>(10 * sequence + 10); }

TEST(SettleTracker, ExactLatencyKeepsFromFirstFramePlusLatency) {
  SettleTracker tracker(3, 3);
  EXPECT_EQ(tracker.on_change(0, 0), 0);
  for (uint64_t s = 0; s < 3; ++s) EXPECT_EQ(tracker.on_frame(s, start_ns(s), true), -1) << s;
  EXPECT_EQ(tracker.first_frame_after(0), 0u);
  for (uint64_t s = 3; s < 8; ++s) EXPECT_EQ(tracker.on_frame(s, start_ns(s), true), 0) << s;
}

TEST(SettleTracker, WindowsOfConsecutiveChangesAreContiguousWithExactLatency) {
  SettleTracker tracker(3, 3);
  tracker.on_change(0, 0);
  EXPECT_EQ(tracker.on_frame(0, start_ns(0), true), -1);
  tracker.on_change(15, 3);  // written after frame 0 arrived: frame 1 is the first after it
  EXPECT_EQ(tracker.on_frame(1, start_ns(1), true), -1);
  EXPECT_EQ(tracker.first_frame_after(1), 1u);
  EXPECT_EQ(tracker.on_frame(2, start_ns(2), true), -1);
  EXPECT_EQ(tracker.on_frame(3, start_ns(3), true), 0);
  EXPECT_TRUE(tracker.window_closed(0, 3));
  EXPECT_EQ(tracker.on_frame(4, start_ns(4), true), 1);
  EXPECT_EQ(tracker.on_frame(9, start_ns(9), true), 1);
}

TEST(SettleTracker, UncertainLatencyLeavesASettlingGapBetweenWindows) {
  SettleTracker tracker(3, 1);
  tracker.on_change(0, 0);
  for (uint64_t s = 0; s < 5; ++s) tracker.on_frame(s, start_ns(s), true);
  tracker.on_change(start_ns(4) + 1, 3);  // first seen by frame 5
  // Change 0 surely holds from 0 + 3 until change 1 may arrive at 5 + 1.
  EXPECT_EQ(tracker.on_frame(5, start_ns(5), true), 0);
  EXPECT_EQ(tracker.on_frame(6, start_ns(6), true), -1);
  EXPECT_EQ(tracker.on_frame(7, start_ns(7), true), -1);
  EXPECT_EQ(tracker.on_frame(8, start_ns(8), true), 1);
}

TEST(SettleTracker, ADroppedFrameMovesTheFirstFrameLaterNeverEarlier) {
  SettleTracker tracker(2, 2);
  tracker.on_change(0, 0);
  tracker.on_frame(0, start_ns(0), true);
  tracker.on_change(15, 3);  // the truth: frame 1 is the first after it, but 1 and 2 are lost
  EXPECT_EQ(tracker.on_frame(3, start_ns(3), true), -1);
  EXPECT_EQ(tracker.first_frame_after(1), 3u);
  EXPECT_EQ(tracker.on_frame(4, start_ns(4), true), -1);
  EXPECT_EQ(tracker.on_frame(5, start_ns(5), true), 1);
}

// Frame 2 started while change 1 was being written (its thread preempted between the
// ioctl and the clock read): the device may have taken it as n, so with latency 2 frame 4
// may already carry change 1. Change 0's window closes before it, and change 1's opens
// only after frame 3, the first that surely started after the write.
TEST(SettleTracker, AFrameThatStartedDuringTheWriteBelongsToNeitherSide) {
  SettleTracker tracker(2, 2);
  tracker.on_change(0, 0);
  tracker.on_frame(0, start_ns(0), true);
  tracker.on_frame(1, start_ns(1), true);
  tracker.on_change(start_ns(2) - 1, start_ns(2) + 1, 3);
  EXPECT_EQ(tracker.on_frame(2, start_ns(2), true), 0);
  EXPECT_EQ(tracker.on_frame(3, start_ns(3), true), 0);
  EXPECT_EQ(tracker.first_frame_after(1), 3u);
  EXPECT_EQ(tracker.on_frame(4, start_ns(4), true), -1) << "may carry change 1";
  EXPECT_EQ(tracker.on_frame(5, start_ns(5), true), 1);
  // The same stream with the write an instant: frame 2 surely before, frame 4 change 0's.
  SettleTracker instant(2, 2);
  instant.on_change(0, 0);
  instant.on_frame(0, start_ns(0), true);
  instant.on_frame(1, start_ns(1), true);
  instant.on_change(start_ns(2) + 1, 3);
  for (uint64_t s = 2; s < 5; ++s) EXPECT_EQ(instant.on_frame(s, start_ns(s), true), 0) << s;
  EXPECT_EQ(instant.on_frame(5, start_ns(5), true), 1);
}

TEST(SettleTracker, WithoutTimestampsEveryBufferInTheDriverCountsAsBefore) {
  SettleTracker tracker(1, 1);
  tracker.on_change(1000, 2);  // two buffers may hold frames that started before it
  EXPECT_EQ(tracker.on_frame(7, 0, false), -1);
  EXPECT_EQ(tracker.on_frame(8, 0, false), -1);
  EXPECT_FALSE(tracker.first_frame_after(0).has_value());
  EXPECT_EQ(tracker.on_frame(9, 0, false), -1);
  EXPECT_EQ(tracker.first_frame_after(0), 9u);
  EXPECT_EQ(tracker.on_frame(10, 0, false), 0);
}

TEST(SettleTracker, SecuredFramesAllowTheNextWriteLatencyFramesEarly) {
  SettleTracker exact(3, 3);
  exact.on_change(0, 0);
  EXPECT_FALSE(exact.frames_secured_after(0, 0).has_value()) << "n unknown before any frame";
  exact.on_frame(0, start_ns(0), true);
  // A write now is first seen by frame 1, so frame 3 = 0 + 3 still carries change 0.
  EXPECT_EQ(exact.frames_secured_after(0, 0), 1);
  EXPECT_EQ(exact.frames_secured_after(0, 1), 2);

  SettleTracker unknown_min(3, 0);
  unknown_min.on_change(0, 0);
  unknown_min.on_frame(0, start_ns(0), true);
  EXPECT_EQ(unknown_min.frames_secured_after(0, 0), 0)
      << "with L_min = 0 only frames already started count";
  EXPECT_FALSE(unknown_min.window_closed(0, 100)) << "no next change";
}

}  // namespace
}  // namespace camlab::capture
