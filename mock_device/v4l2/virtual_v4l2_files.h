// The open files of the virtual V4L2 device and what each keeps of its own, as the
// kernel's struct v4l2_fh does: its priority (v4l2_prio_*), its control event
// subscriptions and the events queued for it, and the eventfd a transport gave it to stand
// for its readiness.
//
// Thread-compatible: the device's mutex serialises every call.
#pragma once

#include <linux/videodev2.h>

#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <vector>

namespace camlab::mock {

class VirtualV4l2Files {
 public:
  // A new open file's id (from 1 up, never reused).
  int add(bool nonblocking);
  void remove(int file);
  bool contains(int file) const { return files_.count(file) != 0; }
  // Every open file's id, in order.
  std::vector<int> ids() const;
  bool nonblocking(int file) const;

  // The device's priority: the highest of any open file's (v4l2_prio_max).
  v4l2_priority max_priority() const;
  // -EBUSY when `file` is below the device's priority (v4l2_prio_check), else 0.
  int check_priority(int file) const;
  // VIDIOC_S_PRIORITY: only a file at the device's priority may change its own.
  int set_priority(int file, uint32_t priority);

  // Control events (V4L2_EVENT_CTRL only). Flags are V4L2_EVENT_SUB_FL_*.
  void subscribe(int file, uint32_t control_id, uint32_t flags);
  int unsubscribe(int file, const v4l2_event_subscription& subscription);
  // Queues `event` (its type, id and u.ctrl) for every file subscribed to its control, or
  // only for `only_file` when it is not 0, except the originator of the change unless it
  // subscribed with ALLOW_FEEDBACK.
  void queue_control_event(const v4l2_event& event, int originator, int only_file);
  bool has_events(int file) const;
  int dqevent(int file, v4l2_event* event);

  // Readiness through eventfds (borrowed: the transport owns them). An attached eventfd is
  // kept readable exactly while `ready(file)` holds; call signal_readiness after anything
  // that may change it.
  void attach_eventfd(int file, int eventfd);
  void signal_readiness(const std::function<bool(int file)>& ready);

 private:
  struct File {
    bool nonblocking = false;
    v4l2_priority priority = V4L2_PRIORITY_DEFAULT;
    std::map<uint32_t, uint32_t> subscriptions;  // control id -> V4L2_EVENT_SUB_FL_* flags
    std::deque<v4l2_event> events;
    uint32_t event_sequence = 0;
    int eventfd = -1;  // borrowed
    bool signalled = false;
  };

  std::map<int, File> files_;
  int next_file_ = 1;
};

}  // namespace camlab::mock
