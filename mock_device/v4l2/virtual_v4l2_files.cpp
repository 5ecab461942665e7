#include "mock_device/v4l2/virtual_v4l2_files.h"

#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>

namespace camlab::mock {

namespace {

timespec monotonic_now() {
  timespec now{};
  clock_gettime(CLOCK_MONOTONIC, &now);
  return now;
}

}  // namespace

int VirtualV4l2Files::add(bool nonblocking) {
  const int id = next_file_++;
  files_[id].nonblocking = nonblocking;
  return id;
}

void VirtualV4l2Files::remove(int file) { files_.erase(file); }

std::vector<int> VirtualV4l2Files::ids() const {
  std::vector<int> out;
  for (const auto& [id, file] : files_) out.push_back(id);
  return out;
}

bool VirtualV4l2Files::nonblocking(int file) const {
  auto it = files_.find(file);
  return it != files_.end() && it->second.nonblocking;
}

v4l2_priority VirtualV4l2Files::max_priority() const {
  v4l2_priority highest = V4L2_PRIORITY_BACKGROUND;
  for (const auto& [id, f] : files_) highest = std::max(highest, f.priority);
  return highest;
}

int VirtualV4l2Files::check_priority(int file) const {
  auto it = files_.find(file);
  return it != files_.end() && it->second.priority < max_priority() ? -EBUSY : 0;
}

int VirtualV4l2Files::set_priority(int file, uint32_t priority) {
  if (priority > V4L2_PRIORITY_RECORD || priority == V4L2_PRIORITY_UNSET) return -EINVAL;
  // Only a file at the device's highest priority may change priorities.
  if (int busy = check_priority(file)) return busy;
  files_[file].priority = static_cast<v4l2_priority>(priority);
  return 0;
}

void VirtualV4l2Files::subscribe(int file, uint32_t control_id, uint32_t flags) {
  files_[file].subscriptions[control_id] = flags;
}

int VirtualV4l2Files::unsubscribe(int file, const v4l2_event_subscription& subscription) {
  File& f = files_[file];
  if (subscription.type == V4L2_EVENT_ALL) {
    f.subscriptions.clear();
  } else if (subscription.type == V4L2_EVENT_CTRL) {
    f.subscriptions.erase(subscription.id);
  } else {
    return -EINVAL;
  }
  // Events of controls no longer subscribed to are dropped undelivered.
  f.events.erase(std::remove_if(f.events.begin(), f.events.end(),
                                [&](const v4l2_event& e) { return !f.subscriptions.count(e.id); }),
                 f.events.end());
  return 0;
}

void VirtualV4l2Files::queue_control_event(const v4l2_event& body, int originator, int only_file) {
  const uint32_t id = body.id;
  for (auto& [file_id, file] : files_) {
    if (only_file != 0 && file_id != only_file) continue;
    auto subscription = file.subscriptions.find(id);
    if (subscription == file.subscriptions.end()) continue;
    // The file that made a change is not told of it unless it asked for feedback.
    if (file_id == originator && !(subscription->second & V4L2_EVENT_SUB_FL_ALLOW_FEEDBACK))
      continue;
    v4l2_event event = body;
    event.sequence = file.event_sequence++;
    event.timestamp = monotonic_now();
    // Like the kernel's one-deep queue per control: a newer change replaces an
    // undelivered one for the same control, keeping both change bits.
    auto same = std::find_if(file.events.begin(), file.events.end(),
                             [&](const v4l2_event& e) { return e.id == id; });
    if (same != file.events.end()) {
      event.u.ctrl.changes |= same->u.ctrl.changes;
      file.events.erase(same);
    }
    file.events.push_back(event);
  }
}

bool VirtualV4l2Files::has_events(int file) const {
  auto it = files_.find(file);
  return it != files_.end() && !it->second.events.empty();
}

int VirtualV4l2Files::dqevent(int file, v4l2_event* event) {
  File& f = files_[file];
  if (f.events.empty()) return -ENOENT;
  *event = f.events.front();
  f.events.pop_front();
  event->pending = static_cast<uint32_t>(f.events.size());
  return 0;
}

void VirtualV4l2Files::attach_eventfd(int file, int eventfd) {
  auto it = files_.find(file);
  if (it == files_.end()) return;
  it->second.eventfd = eventfd;
  it->second.signalled = false;
}

void VirtualV4l2Files::signal_readiness(const std::function<bool(int file)>& ready) {
  for (auto& [id, f] : files_) {
    if (f.eventfd < 0) continue;
    const bool now_ready = ready(id);
    if (now_ready == f.signalled) continue;
    uint64_t count = 1;
    // The eventfd is non-blocking: write sets it readable, read drains it.
    const ssize_t n = now_ready ? ::write(f.eventfd, &count, sizeof count)
                                : ::read(f.eventfd, &count, sizeof count);
    if (n == sizeof count) f.signalled = now_ready;
  }
}

}  // namespace camlab::mock
