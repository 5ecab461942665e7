// The virtual camera's V4L2 controls: the user and camera class controls its spec
// describes (gain, exposure mode and time, focus mode and position, iris), the value each
// has, the value in effect at the sensor, and new values on their way there. A value set
// while streaming reaches the sensor latency_frames after the next frame to start, as a
// sensor's registers latch at a frame boundary; without a stream it applies at once.
//
// It answers the bodies of the control ioctls with v4l2-ctrls.c's rules (the NEXT_CTRL
// walk, step rounding and clamping, menu holes, error_idx) and tells a listener of every
// change of value or flags, for the device to send as V4L2_EVENT_CTRL. Priorities and open
// files are the device's.
//
// Thread-compatible: the device's mutex serialises every call.
#pragma once

#include <linux/videodev2.h>

#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <vector>

#include "mock_device/spec/camera_spec.h"

namespace camlab::mock {

class VirtualV4l2Controls {
 public:
  struct Control {
    v4l2_query_ext_ctrl query{};
    int64_t value = 0;
    std::vector<const char*> menu;  // for menus: names by index (nullptr = hole)
  };
  // A change of a control (V4L2_EVENT_CTRL_CH_* bits); `by_caller`: made by the file whose
  // ioctl is being answered (not told of it unless it asked for feedback), rather than a
  // side effect such as an auto mode making its manual control inactive.
  using ChangeListener = std::function<void(uint32_t id, uint32_t changes, bool by_caller)>;

  VirtualV4l2Controls(const ControlsSpec& spec, int latency_frames);

  const Control* find(uint32_t id) const;

  int query_ext_ctrl(v4l2_query_ext_ctrl* query) const;
  int queryctrl(v4l2_queryctrl* query) const;
  int querymenu(v4l2_querymenu* item) const;

  // The checks of G/S/TRY_EXT_CTRLS that come before the device's priority check: the
  // array and `which`. get, try_set and set make them too.
  int check_request(unsigned long request, const v4l2_ext_controls& controls) const;
  int get(v4l2_ext_controls* controls) const;
  int try_set(v4l2_ext_controls* controls) const;
  // Sets every control or none. `next_frame`: the sequence number of the next frame to
  // start, nullopt when not streaming.
  int set(v4l2_ext_controls* controls, std::optional<uint64_t> next_frame,
          const ChangeListener& changed);

  // The body of a V4L2_EVENT_CTRL for control `id` as it is now (type, id, u.ctrl); the
  // file it goes to numbers and stamps it.
  v4l2_event event(uint32_t id, uint32_t changes) const;

  // The value the sensor uses now.
  int64_t in_effect(uint32_t id) const { return in_effect_.at(id); }
  // Values whose latency has passed reach the sensor with frame `sequence`.
  void apply_due(uint64_t sequence);
  // The stream stopped: no frame is in flight, every pending value applies.
  void apply_pending();

 private:
  struct PendingControl {
    uint64_t apply_at_sequence;
    uint32_t id;
    int64_t value;
  };

  Control* find_mutable(uint32_t id);
  void add(const v4l2_query_ext_ctrl& query, int64_t value);
  // G (get), TRY or S of every control in the array, before any is read or changed.
  int validate(unsigned long request, v4l2_ext_controls* controls) const;
  int set_value(Control& c, int64_t value, std::optional<uint64_t> next_frame,
                const ChangeListener& changed);

  int latency_frames_;
  std::map<uint32_t, Control> controls_;   // by id, in id order (NEXT_CTRL walks it)
  std::map<uint32_t, int64_t> in_effect_;  // control values the sensor uses now
  std::vector<PendingControl> pending_;
};

}  // namespace camlab::mock
