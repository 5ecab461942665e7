// The virtual sensor's frame clock: the frame interval (the sensor's, or twice it for
// longer exposures, as S_PARM picks), the sequence number of the next frame, and the
// pacing of the device's producer thread. In real time it ticks once per interval, and a
// tick that comes late (a frame that took longer than the interval to render) skips
// sequence numbers, as a sensor that cannot keep up would; otherwise frames come as fast
// as they render. Faults for tests: frames to drop (gaps in the sequence) and a stall (no
// ticks until cleared).
//
// Thread-compatible: the device's mutex serialises every call; the producer thread waits
// for next_tick() on the device's condition variable.
#pragma once

#include <linux/videodev2.h>

#include <chrono>
#include <cstdint>
#include <optional>

namespace camlab::mock {

// A frame interval as kernel drivers report it: 1/30 for 33333 or 33333.3 us, not
// 33333/1000000 (ustreamer refuses a numerator other than 1; GStreamer shows 1000000/33333
// fps). Within half a microsecond of a whole frame rate gives 1/fps, of an NTSC rate
// 1001/(1000 fps); anything else the microseconds over 10^6, reduced. `multiple` times
// the interval is that fraction's multiple (twice 33333 us is 1/15, not 33333/500000).
v4l2_fract frame_interval_fraction(double interval_us, uint32_t multiple = 1);

class VirtualV4l2FrameClock {
 public:
  using Clock = std::chrono::steady_clock;

  VirtualV4l2FrameClock(double sensor_frame_interval_us, bool realtime);

  v4l2_fract time_per_frame() const { return time_per_frame_; }
  // S_PARM: the sensor's interval, or twice it when more than 1.5 times it is asked for
  // (a zero denominator asks for the sensor's).
  void set_time_per_frame(v4l2_fract asked);
  std::chrono::microseconds interval() const;
  bool realtime() const { return realtime_; }

  // STREAMON: frames count from 0 again. A clock still running (a STREAMOFF and STREAMON
  // between two of the producer's looks) keeps its ticks: the next one is frame 0's.
  void restart_sequence() {
    next_sequence_ = 0;
    origin_ = next_tick_;
  }
  uint64_t next_sequence() const { return next_sequence_; }
  // The first frame that has not started at `now`: in real time a frame starts at its tick
  // (its timestamp), though the producer may take its sequence number later on a loaded
  // machine; a control written after the tick must not reach that frame. As fast as
  // rendered, the next sequence number the producer takes.
  uint64_t first_unstarted(Clock::time_point now) const;

  // Ticking: from start() until stop().
  bool running() const { return running_; }
  // The next sequence number's tick is now (a restart after a slow first frame moves the
  // grid, the frames before it with it); on a shared grid (set_grid), the grid's next tick.
  void start();
  // A rig's frame clock: every tick of every camera on `origin` + k x interval (plus the
  // camera's trigger offset), as cameras that one trigger line fires. start() then waits
  // for the grid's next tick instead of starting at once.
  void set_grid(Clock::time_point origin) { grid_origin_ = origin; }
  bool on_grid() const { return grid_origin_.has_value(); }
  // Frame `sequence`'s tick counted on the shared grid (the same number in every camera of a
  // rig for frames one trigger starts); without a grid or a real-time clock, the sequence.
  int64_t grid_tick_index(uint64_t sequence) const;
  void stop() { running_ = false; }
  Clock::time_point next_tick() const { return next_tick_; }
  // Past the tick just waited for, to the next one; ticks already missed cost their
  // sequence numbers.
  void advance();
  // The sequence number of the frame starting now.
  uint64_t take_sequence() { return next_sequence_++; }
  // When frame `sequence` starts on the running clock's grid: the tick of the frame that
  // start() made current, plus whole intervals. A buffer's timestamp, so that timestamps
  // and sequence numbers always tell the same gaps (a frame rendered late is still stamped
  // on its tick).
  Clock::time_point tick_of(uint64_t sequence) const;

  void drop_next_frames(int count) { drop_frames_ = count; }
  bool dropping() const { return drop_frames_ > 0; }
  // Whether the frame starting now is to be dropped (counts it off).
  bool take_drop();

  void stall(bool stalled) { stalled_ = stalled; }
  bool stalled() const { return stalled_; }

 private:
  double sensor_frame_interval_us_;
  bool realtime_;
  v4l2_fract time_per_frame_{};
  uint64_t next_sequence_ = 0;
  bool running_ = false;
  Clock::time_point next_tick_{};
  Clock::time_point origin_{};  // sequence 0's tick on the running grid
  int drop_frames_ = 0;
  bool stalled_ = false;
  std::optional<Clock::time_point> grid_origin_;
};

}  // namespace camlab::mock
