#include "mock_device/v4l2/virtual_v4l2_controls.h"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <iterator>

namespace camlab::mock {

namespace {

constexpr uint32_t kIdFlags = V4L2_CTRL_FLAG_NEXT_CTRL | V4L2_CTRL_FLAG_NEXT_COMPOUND;

const char* const kExposureMenu[] = {nullptr, "Manual Mode", nullptr, "Aperture Priority Mode"};

v4l2_query_ext_ctrl make_query(uint32_t id, uint32_t type, const char* name, int64_t min,
                               int64_t max, uint64_t step, int64_t def, uint32_t flags = 0) {
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

}  // namespace

VirtualV4l2Controls::VirtualV4l2Controls(const ControlsSpec& c, int latency_frames)
    : latency_frames_(latency_frames) {
  const uint32_t class_flags = V4L2_CTRL_FLAG_READ_ONLY | V4L2_CTRL_FLAG_WRITE_ONLY;
  add(make_query(V4L2_CID_USER_CLASS, V4L2_CTRL_TYPE_CTRL_CLASS, "User Controls", 0, 0, 0, 0,
                 class_flags),
      0);
  add(make_query(V4L2_CID_GAIN, V4L2_CTRL_TYPE_INTEGER, "Gain", c.gain.min, c.gain.max, c.gain.step,
                 c.gain.default_value),
      c.gain.default_value);
  add(make_query(V4L2_CID_CAMERA_CLASS, V4L2_CTRL_TYPE_CTRL_CLASS, "Camera Controls", 0, 0, 0, 0,
                 class_flags),
      0);
  const int exposure_mode =
      c.exposure_auto ? V4L2_EXPOSURE_APERTURE_PRIORITY : V4L2_EXPOSURE_MANUAL;
  add(make_query(V4L2_CID_EXPOSURE_AUTO, V4L2_CTRL_TYPE_MENU, "Auto Exposure", V4L2_EXPOSURE_MANUAL,
                 V4L2_EXPOSURE_APERTURE_PRIORITY, 1, exposure_mode, V4L2_CTRL_FLAG_UPDATE),
      exposure_mode);
  controls_[V4L2_CID_EXPOSURE_AUTO].menu.assign(std::begin(kExposureMenu), std::end(kExposureMenu));
  const ControlRange& e = c.exposure_time_absolute;
  add(make_query(V4L2_CID_EXPOSURE_ABSOLUTE, V4L2_CTRL_TYPE_INTEGER, "Exposure Time, Absolute",
                 e.min, e.max, e.step, e.default_value,
                 c.exposure_auto ? V4L2_CTRL_FLAG_INACTIVE : 0),
      e.default_value);
  const ControlRange& f = c.focus_absolute;
  add(make_query(V4L2_CID_FOCUS_ABSOLUTE, V4L2_CTRL_TYPE_INTEGER, "Focus, Absolute", f.min, f.max,
                 f.step, f.default_value, c.focus_auto ? V4L2_CTRL_FLAG_INACTIVE : 0),
      f.default_value);
  add(make_query(V4L2_CID_FOCUS_AUTO, V4L2_CTRL_TYPE_BOOLEAN, "Focus, Automatic Continuous", 0, 1,
                 1, c.focus_auto ? 1 : 0, V4L2_CTRL_FLAG_UPDATE),
      c.focus_auto ? 1 : 0);
  const ControlRange& i = c.iris_absolute;
  add(make_query(V4L2_CID_IRIS_ABSOLUTE, V4L2_CTRL_TYPE_INTEGER, "Iris, Absolute", i.min, i.max,
                 i.step, i.default_value),
      i.default_value);
}

void VirtualV4l2Controls::add(const v4l2_query_ext_ctrl& query, int64_t value) {
  Control control;
  control.query = query;
  control.value = value;
  controls_[query.id] = control;
  in_effect_[query.id] = value;
}

const VirtualV4l2Controls::Control* VirtualV4l2Controls::find(uint32_t id) const {
  auto it = controls_.find(id);
  return it == controls_.end() ? nullptr : &it->second;
}

VirtualV4l2Controls::Control* VirtualV4l2Controls::find_mutable(uint32_t id) {
  auto it = controls_.find(id);
  return it == controls_.end() ? nullptr : &it->second;
}

int VirtualV4l2Controls::query_ext_ctrl(v4l2_query_ext_ctrl* query) const {
  const uint32_t id = query->id & ~kIdFlags;
  const Control* found = nullptr;
  // Every control here is a plain (non-compound) one: NEXT_COMPOUND alone finds none.
  if ((query->id & kIdFlags) == V4L2_CTRL_FLAG_NEXT_COMPOUND) return -EINVAL;
  if (query->id & kIdFlags) {
    auto it = controls_.upper_bound(id);
    if (it != controls_.end()) found = &it->second;
  } else {
    found = find(id);
  }
  if (!found) return -EINVAL;
  *query = found->query;
  return 0;
}

int VirtualV4l2Controls::queryctrl(v4l2_queryctrl* old) const {
  // As v4l2-ctrls: the old ioctl is the extended one, its answer cut to the old struct.
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

int VirtualV4l2Controls::querymenu(v4l2_querymenu* item) const {
  const Control* c = find(item->id);
  if (!c || c->query.type != V4L2_CTRL_TYPE_MENU || item->index < c->query.minimum ||
      item->index > c->query.maximum || c->menu[item->index] == nullptr)
    return -EINVAL;
  std::memset(item->name, 0, sizeof item->name);
  std::strncpy(reinterpret_cast<char*>(item->name), c->menu[item->index], sizeof item->name - 1);
  item->reserved = 0;
  return 0;
}

int VirtualV4l2Controls::check_request(unsigned long request,
                                       const v4l2_ext_controls& controls) const {
  const bool get = request == VIDIOC_G_EXT_CTRLS;
  if (controls.count > 1024) return -EINVAL;
  if (controls.count > 0 && controls.controls == nullptr) return -EFAULT;
  const uint32_t which = controls.which;
  if (which != V4L2_CTRL_WHICH_CUR_VAL && which != V4L2_CTRL_WHICH_DEF_VAL &&
      which != V4L2_CTRL_CLASS_USER && which != V4L2_CTRL_CLASS_CAMERA)
    return -EINVAL;
  if (which == V4L2_CTRL_WHICH_DEF_VAL && !get) return -EINVAL;
  return 0;
}

int VirtualV4l2Controls::validate(unsigned long request, v4l2_ext_controls* controls) const {
  const bool get = request == VIDIOC_G_EXT_CTRLS, set = request == VIDIOC_S_EXT_CTRLS;
  const uint32_t which = controls->which;
  // Validate every id first: nothing changes unless all of them are good.
  for (uint32_t i = 0; i < controls->count; ++i) {
    const v4l2_ext_control& ext = controls->controls[i];
    const Control* c = find(ext.id);
    const bool wrong_class = (which == V4L2_CTRL_CLASS_USER || which == V4L2_CTRL_CLASS_CAMERA) &&
                             V4L2_CTRL_ID2WHICH(ext.id) != which;
    // error_idx as the kernel reports it: S_EXT_CTRLS says count for any failure found
    // while checking (nothing was applied), TRY and G name the failing control.
    if (!c || wrong_class) {
      controls->error_idx = set ? controls->count : i;
      return -EINVAL;
    }
    if ((get && (c->query.flags & V4L2_CTRL_FLAG_WRITE_ONLY)) ||
        (!get && (c->query.flags & V4L2_CTRL_FLAG_READ_ONLY))) {
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
  return 0;
}

int VirtualV4l2Controls::get(v4l2_ext_controls* controls) const {
  if (int error = check_request(VIDIOC_G_EXT_CTRLS, *controls)) return error;
  if (int error = validate(VIDIOC_G_EXT_CTRLS, controls)) return error;
  for (uint32_t i = 0; i < controls->count; ++i) {
    v4l2_ext_control& ext = controls->controls[i];
    const Control& c = *find(ext.id);
    ext.value = static_cast<int32_t>(
        controls->which == V4L2_CTRL_WHICH_DEF_VAL ? c.query.default_value : c.value);
  }
  return 0;
}

int VirtualV4l2Controls::try_set(v4l2_ext_controls* controls) const {
  if (int error = check_request(VIDIOC_TRY_EXT_CTRLS, *controls)) return error;
  return validate(VIDIOC_TRY_EXT_CTRLS, controls);
}

int VirtualV4l2Controls::set(v4l2_ext_controls* controls, std::optional<uint64_t> next_frame,
                             const ChangeListener& changed) {
  if (int error = check_request(VIDIOC_S_EXT_CTRLS, *controls)) return error;
  if (int error = validate(VIDIOC_S_EXT_CTRLS, controls)) return error;
  for (uint32_t i = 0; i < controls->count; ++i) {
    v4l2_ext_control& ext = controls->controls[i];
    Control& c = *find_mutable(ext.id);
    if (int error = set_value(c, ext.value, next_frame, changed)) {
      controls->error_idx = i;
      return error;
    }
    ext.value = static_cast<int32_t>(c.value);
  }
  return 0;
}

int VirtualV4l2Controls::set_value(Control& c, int64_t value, std::optional<uint64_t> next_frame,
                                   const ChangeListener& changed) {
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
  const bool value_changed = c.value != value;
  c.value = value;
  // The sensor takes a new value `latency` frames after the next frame starts; without a
  // stream there is no frame in flight and it applies at once.
  if (next_frame)
    pending_.push_back({*next_frame + static_cast<uint64_t>(latency_frames_), c.query.id, value});
  else
    in_effect_[c.query.id] = value;
  if (value_changed) changed(c.query.id, V4L2_EVENT_CTRL_CH_VALUE, true);

  // Auto modes make their manual control inactive.
  auto toggle_inactive = [&](uint32_t id, bool inactive) {
    Control* dependent = find_mutable(id);
    const uint32_t before = dependent->query.flags;
    dependent->query.flags =
        inactive ? (before | V4L2_CTRL_FLAG_INACTIVE) : (before & ~V4L2_CTRL_FLAG_INACTIVE);
    if (before != dependent->query.flags) changed(id, V4L2_EVENT_CTRL_CH_FLAGS, false);
  };
  if (c.query.id == V4L2_CID_EXPOSURE_AUTO)
    toggle_inactive(V4L2_CID_EXPOSURE_ABSOLUTE, value != V4L2_EXPOSURE_MANUAL);
  if (c.query.id == V4L2_CID_FOCUS_AUTO) toggle_inactive(V4L2_CID_FOCUS_ABSOLUTE, value != 0);
  return 0;
}

v4l2_event VirtualV4l2Controls::event(uint32_t id, uint32_t changes) const {
  v4l2_event event{};
  const Control* c = find(id);
  if (!c) return event;
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
  return event;
}

void VirtualV4l2Controls::apply_due(uint64_t sequence) {
  for (auto it = pending_.begin(); it != pending_.end();) {
    if (it->apply_at_sequence <= sequence) {
      in_effect_[it->id] = it->value;
      it = pending_.erase(it);
    } else {
      ++it;
    }
  }
}

void VirtualV4l2Controls::apply_pending() {
  for (const auto& p : pending_) in_effect_[p.id] = p.value;
  pending_.clear();
}

}  // namespace camlab::mock
