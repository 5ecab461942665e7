// The virtual sensor's frame clock on its own: the intervals S_PARM may choose, late
// ticks that cost sequence numbers, and the dropped-frame and stall faults.
#include "mock_device/v4l2/virtual_v4l2_frame_clock.h"

#include <gtest/gtest.h>

#include <thread>

namespace camlab::mock {
namespace {

bool same(v4l2_fract a, v4l2_fract b) {
  return a.numerator == b.numerator && a.denominator == b.denominator;
}

TEST(VirtualV4l2FrameClock, TimePerFrameIsTheSensorsIntervalOrTwiceIt) {
  VirtualV4l2FrameClock clock(33333.3, true);
  EXPECT_TRUE(same(clock.time_per_frame(), {1, 30})) << "as drivers report 30 fps";
  EXPECT_EQ(clock.interval(), std::chrono::microseconds(33333));
  clock.set_time_per_frame({1, 15});  // 66.7 ms
  EXPECT_TRUE(same(clock.time_per_frame(), {1, 15}));
  VirtualV4l2FrameClock whole_us(33333, true);  // as specs give it
  whole_us.set_time_per_frame({1, 15});
  EXPECT_TRUE(same(whole_us.time_per_frame(), {1, 15}));
  clock.set_time_per_frame({1, 25});  // 40 ms: nearer the sensor's
  EXPECT_TRUE(same(clock.time_per_frame(), {1, 30}));
  clock.set_time_per_frame({1, 15});
  clock.set_time_per_frame({1, 0});  // no denominator: the sensor's
  EXPECT_TRUE(same(clock.time_per_frame(), {1, 30}));
}

TEST(VirtualV4l2FrameClock, IntervalsAreTheFractionsDriversReport) {
  EXPECT_TRUE(same(frame_interval_fraction(33333.3), {1, 30}));
  EXPECT_TRUE(same(frame_interval_fraction(33333), {1, 30})) << "whole microseconds, as specs give";
  EXPECT_TRUE(same(frame_interval_fraction(16667), {1, 60}));
  EXPECT_TRUE(same(frame_interval_fraction(33367), {1001, 30000})) << "29.97 fps in whole us";
  EXPECT_TRUE(same(frame_interval_fraction(16666.7), {1, 60}));
  EXPECT_TRUE(same(frame_interval_fraction(40000), {1, 25}));
  EXPECT_TRUE(same(frame_interval_fraction(1e6), {1, 1}));
  EXPECT_TRUE(same(frame_interval_fraction(33366.7), {1001, 30000})) << "29.97 fps";
  EXPECT_TRUE(same(frame_interval_fraction(12345), {2469, 200000})) << "no whole rate: reduced";
  EXPECT_TRUE(same(frame_interval_fraction(2e6), {2, 1})) << "half a frame per second";
  // Multiples of an interval are multiples of its fraction, not of its rounded microseconds.
  EXPECT_TRUE(same(frame_interval_fraction(33333, 2), {1, 15}));
  EXPECT_TRUE(same(frame_interval_fraction(16667, 2), {1, 30}));
  EXPECT_TRUE(same(frame_interval_fraction(33367, 2), {1001, 15000}));
  EXPECT_TRUE(same(frame_interval_fraction(12345, 2), {2469, 100000}));
}

TEST(VirtualV4l2FrameClock, SequenceNumbersCountFromStreamon) {
  VirtualV4l2FrameClock clock(10000, false);
  EXPECT_EQ(clock.take_sequence(), 0u);
  EXPECT_EQ(clock.take_sequence(), 1u);
  EXPECT_EQ(clock.next_sequence(), 2u);
  clock.restart_sequence();
  EXPECT_EQ(clock.take_sequence(), 0u);
}

TEST(VirtualV4l2FrameClock, LateTicksCostSequenceNumbers) {
  VirtualV4l2FrameClock clock(50000, true);
  EXPECT_FALSE(clock.running());
  clock.start();
  EXPECT_TRUE(clock.running());
  const auto first_tick = clock.next_tick();
  EXPECT_LE(first_tick, VirtualV4l2FrameClock::Clock::now());
  clock.advance();  // on time: the next tick, no gap
  EXPECT_EQ(clock.next_tick(), first_tick + std::chrono::milliseconds(50));
  EXPECT_EQ(clock.next_sequence(), 0u);
  // A frame that took 3.5 intervals: the ticks it missed are lost frames.
  std::this_thread::sleep_until(clock.next_tick() + std::chrono::milliseconds(175));
  clock.advance();
  EXPECT_GE(clock.next_sequence(), 2u);
  clock.stop();
  EXPECT_FALSE(clock.running());
}

// Timestamps: every frame's tick is the grid's, whatever ticks were missed before it; a
// restart (after a slow first frame) moves the grid so that the next frame's tick is now.
TEST(VirtualV4l2FrameClock, EachSequenceNumbersTickIsOnTheGrid) {
  VirtualV4l2FrameClock clock(20000, true);
  clock.start();
  const auto zero = clock.tick_of(0);
  EXPECT_EQ(zero, clock.next_tick());
  clock.advance();  // the first frame's tick is the start
  EXPECT_EQ(clock.take_sequence(), 0u);
  std::this_thread::sleep_until(clock.next_tick() + std::chrono::milliseconds(50));
  clock.advance();  // late: two ticks lost
  const uint64_t late = clock.take_sequence();
  EXPECT_GE(late, 2u);
  EXPECT_EQ(clock.tick_of(late), zero + std::chrono::milliseconds(20) * static_cast<int>(late));
  EXPECT_LE(clock.tick_of(late), VirtualV4l2FrameClock::Clock::now());
  // A restart: the next frame's tick is now, and the grid keeps one interval per number.
  clock.start();
  const uint64_t next = clock.next_sequence();
  EXPECT_EQ(clock.tick_of(next), clock.next_tick());
  EXPECT_EQ(clock.tick_of(next) - clock.tick_of(next - 1), std::chrono::milliseconds(20));
  // A new stream while the clock still runs (STREAMOFF and STREAMON between two ticks):
  // frame 0 is the next tick's, not the old stream's first (whose time would put every
  // frame before any control written now: camlabd's settle tracker then kept none).
  clock.advance();
  clock.take_sequence();
  clock.restart_sequence();
  EXPECT_EQ(clock.next_sequence(), 0u);
  EXPECT_EQ(clock.tick_of(0), clock.next_tick());
  EXPECT_GT(clock.tick_of(0), zero);
}

// A frame starts at its tick, the time its buffer is stamped with, even when a loaded
// producer takes its sequence number later: a control written after the tick must count
// from the frame after it, or a client that compares the timestamp with the time of its
// write keeps one frame with the new value for the old (camlabd's lens map under load).
TEST(VirtualV4l2FrameClock, TheFirstUnstartedFrameIsTheFirstWhoseTickIsToCome) {
  using std::chrono::milliseconds;
  VirtualV4l2FrameClock clock(20000, true);
  EXPECT_EQ(clock.first_unstarted(VirtualV4l2FrameClock::Clock::now()), 0u) << "not running";
  clock.start();
  const auto zero = clock.tick_of(0);
  clock.advance();
  EXPECT_EQ(clock.take_sequence(), 0u);
  EXPECT_EQ(clock.first_unstarted(zero + milliseconds(10)), 1u);
  EXPECT_EQ(clock.first_unstarted(zero + milliseconds(20)), 2u) << "frame 1 starts at its tick";
  EXPECT_EQ(clock.first_unstarted(zero + milliseconds(75)), 4u) << "the producer is late";
  EXPECT_EQ(clock.next_sequence(), 1u);
  VirtualV4l2FrameClock as_rendered(20000, false);
  as_rendered.start();
  as_rendered.take_sequence();
  EXPECT_EQ(as_rendered.first_unstarted(zero + milliseconds(75)), 1u)
      << "as fast as rendered, a frame starts when the producer takes it";
}

TEST(VirtualV4l2FrameClock, DropsAndStallsAreFaultsForTests) {
  VirtualV4l2FrameClock clock(10000, true);
  EXPECT_FALSE(clock.take_drop());
  clock.drop_next_frames(2);
  EXPECT_TRUE(clock.dropping());
  EXPECT_TRUE(clock.take_drop());
  EXPECT_TRUE(clock.take_drop());
  EXPECT_FALSE(clock.take_drop());
  EXPECT_FALSE(clock.dropping());
  clock.stall(true);
  EXPECT_TRUE(clock.stalled());
  clock.stall(false);
  EXPECT_FALSE(clock.stalled());
}

}  // namespace
}  // namespace camlab::mock
