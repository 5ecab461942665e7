// VirtualV4l2Device: controls (QUERYCTRL, QUERY_EXT_CTRL, QUERYMENU, G/S_CTRL,
// G/S/TRY_EXT_CTRLS), control events, and the latency of new values in frames.
#include <linux/videodev2.h>
#include <time.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "mock_device/v4l2/virtual_v4l2_device.h"

namespace camlab::mock {

namespace {

constexpr uint32_t kIdFlags = V4L2_CTRL_FLAG_NEXT_CTRL | V4L2_CTRL_FLAG_NEXT_COMPOUND;

const char* const kExposureMenu[] = {nullptr, "Manual Mode", nullptr, "Aperture Priority Mode"};

v4l2_query_ext_ctrl make_query(uint32_t id, uint32_t type, const char* name, int64_t min, int64_t max,
                               uint64_t step, int64_t def, uint32_t flags = 0) {
  v4l2_query_ext_ctrl q{};
  q.id = id;
  q.type = type;
  std::strncpy(q.name, name, sizeof q.name - 1);
  q.minimum = min;
  q.maximum = max;
  q.step = step;
  q.default_value = def;
  q.flags = flags;
  q.elem_size = type == V4L2_CTRL_TYPE_INTEGER64 ? 8 : 4;
  q.elems = 1;
  q.nr_of_dims = 0;
  return q;
}

timespec monotonic_now() {
  timespec now{};
  clock_gettime(CLOCK_MONOTONIC, &now);
  return now;
}

}  // namespace

void VirtualV4l2Device::add_controls() {
  const ControlsSpec& c = renderer_.camera().controls;
  auto add = [this](v4l2_query_ext_ctrl query, int64_t value) {
    Control control;
    control.query = query;
    control.value = value;
    controls_[query.id] = control;
    in_effect_[query.id] = value;
  };
  const uint32_t class_flags = V4L2_CTRL_FLAG_READ_ONLY | V4L2_CTRL_FLAG_WRITE_ONLY;
  add(make_query(V4L2_CID_USER_CLASS, V4L2_CTRL_TYPE_CTRL_CLASS, "User Controls", 0, 0, 0, 0, class_flags), 0);
  add(make_query(V4L2_CID_GAIN, V4L2_CTRL_TYPE_INTEGER, "Gain", c.gain.min, c.gain.max, c.gain.step,
                 c.gain.default_value),
      c.gain.default_value);
  add(make_query(V4L2_CID_CAMERA_CLASS, V4L2_CTRL_TYPE_CTRL_CLASS, "Camera Controls", 0, 0, 0, 0, class_flags), 0);
  const int exposure_mode = c.exposure_auto ? V4L2_EXPOSURE_APERTURE_PRIORITY : V4L2_EXPOSURE_MANUAL;
  add(make_query(V4L2_CID_EXPOSURE_AUTO, V4L2_CTRL_TYPE_MENU, "Auto Exposure", V4L2_EXPOSURE_MANUAL,
                 V4L2_EXPOSURE_APERTURE_PRIORITY, 1, exposure_mode, V4L2_CTRL_FLAG_UPDATE),
      exposure_mode);
  controls_[V4L2_CID_EXPOSURE_AUTO].menu.assign(std::begin(kExposureMenu), std::end(kExposureMenu));
  const ControlRange& e = c.exposure_time_absolute;
  add(make_query(V4L2_CID_EXPOSURE_ABSOLUTE, V4L2_CTRL_TYPE_INTEGER, "Exposure Time, Absolute", e.min, e.max,
                 e.step, e.default_value, c.exposure_auto ? V4L2_CTRL_FLAG_INACTIVE : 0),
      e.default_value);
  const ControlRange& f = c.focus_absolute;
  add(make_query(V4L2_CID_FOCUS_ABSOLUTE, V4L2_CTRL_TYPE_INTEGER, "Focus, Absolute", f.min, f.max, f.step,
                 f.default_value, c.focus_auto ? V4L2_CTRL_FLAG_INACTIVE : 0),
      f.default_value);
  add(make_query(V4L2_CID_FOCUS_AUTO, V4L2_CTRL_TYPE_BOOLEAN, "Focus, Automatic Continuous", 0, 1, 1,
                 c.focus_auto ? 1 : 0, V4L2_CTRL_FLAG_UPDATE),
      c.focus_auto ? 1 : 0);
  const ControlRange& i = c.iris_absolute;
  add(make_query(V4L2_CID_IRIS_ABSOLUTE, V4L2_CTRL_TYPE_INTEGER, "Iris, Absolute", i.min, i.max, i.step,
                 i.default_value),
      i.default_value);
}

VirtualV4l2Device::Control* VirtualV4l2Device::control(uint32_t id) {
  auto it = controls_.find(id);
  return it == controls_.end() ? nullptr : &it->second;
}

int VirtualV4l2Device::query_ext_ctrl(v4l2_query_ext_ctrl* query) {
  const uint32_t id = query->id & ~kIdFlags;
  const Control* found = nullptr;
  // Every control here is a plain (non-compound) one: NEXT_COMPOUND alone finds none.
  if ((query->id & kIdFlags) == V4L2_CTRL_FLAG_NEXT_COMPOUND) return -EINVAL;
  if (query->id & kIdFlags) {
    auto it = controls_.upper_bound(id);
    if (it != controls_.end()) found = &it->second;
  } else {
    found = control(id);
  }
  if (!found) return -EINVAL;
  *query = found->query;
  return 0;
}

void VirtualV4l2Device::queue_control_event(uint32_t id, uint32_t changes, int originator, int only_file) {
  const Control* c = control(id);
  if (!c) return;
  for (auto& [file_id, file] : files_) {
    if (only_file != 0 && file_id != only_file) continue;
    auto subscription = file.subscriptions.find(id);
    if (subscription == file.subscriptions.end()) continue;
    // The file that made a change is not told of it unless it asked for feedback.
    if (file_id == originator && !(subscription->second & V4L2_EVENT_SUB_FL_ALLOW_FEEDBACK)) continue;
    v4l2_event event{};
    event.type = V4L2_EVENT_CTRL;
    event.id = id;
    event.u.ctrl.changes = changes;
    event.u.ctrl.type = c->query.type;
    event.u.ctrl.value64 = c->value;
    event.u.ctrl.flags = c->query.flags;
    event.u.ctrl.minimum = static_cast<int32_t>(c->query.minimum);
    event.u.ctrl.maximum = static_cast<int32_t>(c->query.maximum);
    event.u.ctrl.step = static_cast<int32_t>(c->query.step);
    event.u.ctrl.default_value = static_cast<int32_t>(c->query.default_value);
    event.sequence = file.event_sequence++;
    event.timestamp = monotonic_now();
    // Like the kernel's one-deep queue per control: a newer change replaces an
    // undelivered one for the same control, keeping both change bits.
    auto same = std::find_if(file.events.begin(), file.events.end(), [&](const v4l2_event& e) { return e.id == id; });
    if (same != file.events.end()) {
      event.u.ctrl.changes |= same->u.ctrl.changes;
      file.events.erase(same);
    }
    file.events.push_back(event);
  }
  signal_readiness();
  changed_.notify_all();
}

int VirtualV4l2Device::set_control_value(int file, Control& c, int64_t value) {
  switch (c.query.type) {
    case V4L2_CTRL_TYPE_INTEGER: {
      // The kernel rounds integer controls onto their step and clamps them to the range.
      const int64_t step = static_cast<int64_t>(std::max<uint64_t>(c.query.step, 1));
      value = std::clamp<int64_t>(value, c.query.minimum, c.query.maximum);
      value = c.query.minimum + (value - c.query.minimum + step / 2) / step * step;
      value = std::min<int64_t>(value, c.query.maximum);
      break;
    }
    case V4L2_CTRL_TYPE_BOOLEAN:
      value = value != 0;
      break;
    case V4L2_CTRL_TYPE_MENU:
      // Outside the range is ERANGE; a hole in the menu inside it is EINVAL (as the kernel).
      if (value < c.query.minimum || value > c.query.maximum) return -ERANGE;
      if (c.menu[static_cast<size_t>(value)] == nullptr) return -EINVAL;
      break;
    default:
      return -EACCES;
  }
  const bool changed = c.value != value;
  c.value = value;
  // The sensor takes a new value `latency` frames after the next frame starts; without a
  // stream there is no frame in flight and it applies at once.
  const int latency = renderer_.camera().timing.control_latency_frames;
  if (streaming_) pending_.push_back({next_sequence_ + static_cast<uint64_t>(latency), c.query.id, value});
  else in_effect_[c.query.id] = value;
  if (changed) queue_control_event(c.query.id, V4L2_EVENT_CTRL_CH_VALUE, file);

  // Auto modes make their manual control inactive.
  auto toggle_inactive = [&](uint32_t id, bool inactive) {
    Control* dependent = control(id);
    const uint32_t before = dependent->query.flags;
    dependent->query.flags = inactive ? (before | V4L2_CTRL_FLAG_INACTIVE) : (before & ~V4L2_CTRL_FLAG_INACTIVE);
    if (before != dependent->query.flags) queue_control_event(id, V4L2_EVENT_CTRL_CH_FLAGS, 0);
  };
  if (c.query.id == V4L2_CID_EXPOSURE_AUTO) toggle_inactive(V4L2_CID_EXPOSURE_ABSOLUTE, value != V4L2_EXPOSURE_MANUAL);
  if (c.query.id == V4L2_CID_FOCUS_AUTO) toggle_inactive(V4L2_CID_FOCUS_ABSOLUTE, value != 0);
  return 0;
}

int VirtualV4l2Device::ext_ctrls(int file, unsigned long request, v4l2_ext_controls* controls) {
  const bool get = request == VIDIOC_G_EXT_CTRLS, set = request == VIDIOC_S_EXT_CTRLS;
  if (controls->count > 1024) return -EINVAL;
  if (controls->count > 0 && controls->controls == nullptr) return -EFAULT;
  const uint32_t which = controls->which;
  if (which != V4L2_CTRL_WHICH_CUR_VAL && which != V4L2_CTRL_WHICH_DEF_VAL &&
      which != V4L2_CTRL_CLASS_USER && which != V4L2_CTRL_CLASS_CAMERA)
    return -EINVAL;
  if (which == V4L2_CTRL_WHICH_DEF_VAL && !get) return -EINVAL;
  if (set)
    if (int busy = check_priority(file)) return busy;
  // Validate every id first: nothing changes unless all of them are good.
  for (uint32_t i = 0; i < controls->count; ++i) {
    v4l2_ext_control& ext = controls->controls[i];
    Control* c = control(ext.id);
    const bool wrong_class = (which == V4L2_CTRL_CLASS_USER || which == V4L2_CTRL_CLASS_CAMERA) &&
                             V4L2_CTRL_ID2WHICH(ext.id) != which;
    // error_idx as the kernel reports it: S_EXT_CTRLS says count for any failure found
    // while checking (nothing was applied), TRY and G name the failing control.
    if (!c || wrong_class) {
      controls->error_idx = set ? controls->count : i;
      return -EINVAL;
    }
    if ((get && (c->query.flags & V4L2_CTRL_FLAG_WRITE_ONLY)) || (!get && (c->query.flags & V4L2_CTRL_FLAG_READ_ONLY))) {
      // For G_EXT_CTRLS the kernel reports count (nothing was read); for TRY/S the index.
      controls->error_idx = get || set ? controls->count : i;
      return -EACCES;
    }
    if (!get && c->query.type == V4L2_CTRL_TYPE_MENU) {
      const bool outside = ext.value < c->query.minimum || ext.value > c->query.maximum;
      if (outside || c->menu[static_cast<size_t>(ext.value)] == nullptr) {
        controls->error_idx = set ? controls->count : i;
        return outside ? -ERANGE : -EINVAL;
      }
    }
  }
  for (uint32_t i = 0; i < controls->count; ++i) {
    v4l2_ext_control& ext = controls->controls[i];
    Control& c = *control(ext.id);
    if (get) {
      ext.value = static_cast<int32_t>(which == V4L2_CTRL_WHICH_DEF_VAL ? c.query.default_value : c.value);
    } else if (set) {
      if (int error = set_control_value(file, c, ext.value)) {
        controls->error_idx = i;
        return error;
      }
      ext.value = static_cast<int32_t>(c.value);
    }
  }
  return 0;
}

int VirtualV4l2Device::control_ioctl(int file, unsigned long request, void* arg) {
  switch (request) {
    case VIDIOC_QUERY_EXT_CTRL:
      return query_ext_ctrl(static_cast<v4l2_query_ext_ctrl*>(arg));
    case VIDIOC_QUERYCTRL: {
      auto* old = static_cast<v4l2_queryctrl*>(arg);
      v4l2_query_ext_ctrl query{};
      query.id = old->id;
      if (int error = query_ext_ctrl(&query)) return error;
      std::memset(old, 0, sizeof *old);
      old->id = query.id;
      old->type = query.type;
      std::memcpy(old->name, query.name, std::min(sizeof old->name - 1, std::strlen(query.name)));
      old->minimum = static_cast<int32_t>(query.minimum);
      old->maximum = static_cast<int32_t>(query.maximum);
      old->step = static_cast<int32_t>(query.step);
      old->default_value = static_cast<int32_t>(query.default_value);
      old->flags = query.flags;
      return 0;
    }
    case VIDIOC_QUERYMENU: {
      auto* item = static_cast<v4l2_querymenu*>(arg);
      const Control* c = control(item->id);
      if (!c || c->query.type != V4L2_CTRL_TYPE_MENU || item->index < c->query.minimum ||
          item->index > c->query.maximum || c->menu[item->index] == nullptr)
        return -EINVAL;
      std::memset(item->name, 0, sizeof item->name);
      std::strncpy(reinterpret_cast<char*>(item->name), c->menu[item->index], sizeof item->name - 1);
      item->reserved = 0;
      return 0;
    }
    case VIDIOC_G_CTRL:
    case VIDIOC_S_CTRL: {
      auto* old = static_cast<v4l2_control*>(arg);
      v4l2_ext_control ext{};
      ext.id = old->id;
      ext.value = old->value;
      v4l2_ext_controls controls{};
      controls.which = V4L2_CTRL_WHICH_CUR_VAL;
      controls.count = 1;
      controls.controls = &ext;
      const Control* c = control(old->id);
      if (!c || c->query.type == V4L2_CTRL_TYPE_CTRL_CLASS) return -EINVAL;
      const int error = ext_ctrls(file, request == VIDIOC_G_CTRL ? VIDIOC_G_EXT_CTRLS : VIDIOC_S_EXT_CTRLS, &controls);
      if (error == 0) old->value = ext.value;
      return error;
    }
    case VIDIOC_G_EXT_CTRLS:
    case VIDIOC_S_EXT_CTRLS:
    case VIDIOC_TRY_EXT_CTRLS:
      return ext_ctrls(file, request, static_cast<v4l2_ext_controls*>(arg));
    case VIDIOC_SUBSCRIBE_EVENT:
    case VIDIOC_UNSUBSCRIBE_EVENT: {
      auto* sub = static_cast<v4l2_event_subscription*>(arg);
      File& f = files_[file];
      if (request == VIDIOC_UNSUBSCRIBE_EVENT) {
        if (sub->type == V4L2_EVENT_ALL) f.subscriptions.clear();
        else if (sub->type == V4L2_EVENT_CTRL) f.subscriptions.erase(sub->id);
        else return -EINVAL;
        f.events.erase(std::remove_if(f.events.begin(), f.events.end(),
                                      [&](const v4l2_event& e) { return !f.subscriptions.count(e.id); }),
                       f.events.end());
        return 0;
      }
      if (sub->type != V4L2_EVENT_CTRL) return -EINVAL;
      if (!control(sub->id)) return -EINVAL;
      f.subscriptions[sub->id] = sub->flags;
      // A control class has no value to report.
      if ((sub->flags & V4L2_EVENT_SUB_FL_SEND_INITIAL) && control(sub->id)->query.type != V4L2_CTRL_TYPE_CTRL_CLASS)
        queue_control_event(sub->id, V4L2_EVENT_CTRL_CH_VALUE | V4L2_EVENT_CTRL_CH_FLAGS, 0, file);
      return 0;
    }
    case VIDIOC_DQEVENT: {
      auto* event = static_cast<v4l2_event*>(arg);
      File& f = files_[file];
      if (f.events.empty()) return -ENOENT;
      *event = f.events.front();
      f.events.pop_front();
      event->pending = static_cast<uint32_t>(f.events.size());
      return 0;
    }
    default:
      return -ENOTTY;
  }
}

}  // namespace camlab::mock
