// VirtualV4l2Device: the ioctl handlers, one per ioctl, called by ioctl() through the
// table in virtual_v4l2_device.cpp with the device mutex held. Each makes the checks that
// span the device's parts (the file's priority, the stream state) in the kernel's order
// and leaves the rest to the part: VirtualV4l2Controls, VirtualV4l2Queue, VirtualV4l2Files,
// VirtualV4l2FrameClock.
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <iterator>
#include <optional>
#include <string>

#include "mock_device/v4l2/virtual_v4l2_device.h"

namespace camlab::mock {

namespace {

void copy_string(uint8_t* dst, size_t size, const std::string& src) {
  std::memset(dst, 0, size);
  std::memcpy(dst, src.data(), std::min(size - 1, src.size()));
}

}  // namespace

// Capabilities, formats, frame intervals, inputs.

int VirtualV4l2Device::querycap(Call& call) {
  auto* cap = call.arg_as<v4l2_capability>();
  std::memset(cap, 0, sizeof *cap);
  copy_string(cap->driver, sizeof cap->driver, "camlab-vcam");
  copy_string(cap->card, sizeof cap->card, renderer_.camera().name);
  copy_string(cap->bus_info, sizeof cap->bus_info,
              "platform:camlab-vcam-" + std::to_string(options_.index));
  cap->version = (6u << 16) | (1u << 8);
  cap->device_caps = V4L2_CAP_VIDEO_CAPTURE | V4L2_CAP_STREAMING | V4L2_CAP_EXT_PIX_FORMAT;
  cap->capabilities = cap->device_caps | V4L2_CAP_DEVICE_CAPS;
  return 0;
}

const OfferedFormat* VirtualV4l2Device::find_format(uint32_t fourcc) const {
  for (const OfferedFormat& f : formats_)
    if (f.fourcc == fourcc) return &f;
  return nullptr;
}

int VirtualV4l2Device::enum_fmt(Call& call) {
  auto* desc = call.arg_as<v4l2_fmtdesc>();
  if (desc->type != V4L2_BUF_TYPE_VIDEO_CAPTURE || desc->index >= formats_.size()) return -EINVAL;
  const uint32_t index = desc->index;
  const OfferedFormat& format = formats_[index];
  std::memset(desc, 0, sizeof *desc);
  desc->index = index;
  desc->type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  desc->pixelformat = format.fourcc;
  desc->flags = format.compressed() ? V4L2_FMT_FLAG_COMPRESSED : 0u;
  copy_string(desc->description, sizeof desc->description, format.description);
  return 0;
}

int VirtualV4l2Device::enum_framesizes(Call& call) {
  auto* size = call.arg_as<v4l2_frmsizeenum>();
  const OfferedFormat* format = find_format(size->pixel_format);
  if (format == nullptr) return -EINVAL;
  const auto frame = frame_size(*format, renderer_.camera().sensor, size->index);
  if (!frame) return -EINVAL;
  const uint32_t index = size->index, fourcc = size->pixel_format;
  std::memset(size, 0, sizeof *size);
  size->index = index;
  size->pixel_format = fourcc;
  size->type = V4L2_FRMSIZE_TYPE_DISCRETE;
  size->discrete.width = frame->width;
  size->discrete.height = frame->height;
  return 0;
}

int VirtualV4l2Device::enum_frameintervals(Call& call) {
  auto* interval = call.arg_as<v4l2_frmivalenum>();
  const CameraSpec& camera = renderer_.camera();
  std::memset(interval->reserved, 0, sizeof interval->reserved);
  const OfferedFormat* format = find_format(interval->pixel_format);
  bool size_ok = false;
  for (uint32_t index = 0; format != nullptr && index < 2; ++index) {
    const auto frame = frame_size(*format, camera.sensor, index);
    size_ok |= interval->width == frame->width && interval->height == frame->height;
  }
  if (!size_ok || interval->index > 1) return -EINVAL;
  interval->type = V4L2_FRMIVAL_TYPE_DISCRETE;
  // The sensor's frame interval, and twice it (for longer exposures).
  interval->discrete =
      frame_interval_fraction(camera.timing.frame_interval_us, 1u << interval->index);
  return 0;
}

int VirtualV4l2Device::set_format(v4l2_format* format, bool apply) {
  if (format->type != V4L2_BUF_TYPE_VIDEO_CAPTURE) return -EINVAL;
  v4l2_pix_format& pix = format->fmt.pix;
  const SensorSpec& sensor = renderer_.camera().sensor;
  const OfferedFormat* offered = find_format(pix.pixelformat);
  if (offered == nullptr) offered = find_format(default_fourcc(sensor));
  // Two sizes: the full sensor, and 2x2 binned. Pick the nearer by area.
  const double full_area = static_cast<double>(sensor.width_px) * sensor.height_px;
  const double asked = static_cast<double>(pix.width) * pix.height;
  const bool binned = asked > 0 && std::abs(asked - full_area / 4.0) < std::abs(asked - full_area);
  fill_pix_format(*offered, *frame_size(*offered, sensor, binned ? 1 : 0), &pix,
                  renderer_.camera().isp);
  if (apply) format_ = pix;
  return 0;
}

int VirtualV4l2Device::g_fmt(Call& call) {
  auto* format = call.arg_as<v4l2_format>();
  if (format->type != V4L2_BUF_TYPE_VIDEO_CAPTURE) return -EINVAL;
  std::memset(&format->fmt, 0, sizeof format->fmt);
  format->fmt.pix = format_;
  return 0;
}

int VirtualV4l2Device::try_fmt(Call& call) { return set_format(call.arg_as<v4l2_format>(), false); }

int VirtualV4l2Device::s_fmt(Call& call) {
  if (int busy = files_.check_priority(call.file)) return busy;
  if (queue_.holds_format()) return -EBUSY;
  return set_format(call.arg_as<v4l2_format>(), true);
}

int VirtualV4l2Device::g_parm(Call& call) {
  auto* parm = call.arg_as<v4l2_streamparm>();
  if (parm->type != V4L2_BUF_TYPE_VIDEO_CAPTURE) return -EINVAL;
  std::memset(&parm->parm, 0, sizeof parm->parm);
  parm->parm.capture.capability = V4L2_CAP_TIMEPERFRAME;
  parm->parm.capture.timeperframe = clock_.time_per_frame();
  parm->parm.capture.readbuffers = 0;
  return 0;
}

int VirtualV4l2Device::s_parm(Call& call) {
  auto* parm = call.arg_as<v4l2_streamparm>();
  if (parm->type != V4L2_BUF_TYPE_VIDEO_CAPTURE) return -EINVAL;
  if (int busy = files_.check_priority(call.file)) return busy;
  if (queue_.streaming()) return -EBUSY;
  clock_.set_time_per_frame(parm->parm.capture.timeperframe);
  return g_parm(call);  // reports the interval chosen
}

int VirtualV4l2Device::enuminput(Call& call) {
  auto* input = call.arg_as<v4l2_input>();
  if (input->index != 0) return -EINVAL;
  std::memset(input, 0, sizeof *input);
  copy_string(input->name, sizeof input->name, "Camera");
  input->type = V4L2_INPUT_TYPE_CAMERA;
  return 0;
}

int VirtualV4l2Device::g_input(Call& call) {
  *call.arg_as<int>() = 0;
  return 0;
}

int VirtualV4l2Device::s_input(Call& call) {
  if (int busy = files_.check_priority(call.file)) return busy;
  return *call.arg_as<int>() == 0 ? 0 : -EINVAL;
}

// Priorities.

int VirtualV4l2Device::g_priority(Call& call) {
  // The priority of the device: the highest of any open file (v4l2_prio_max).
  *call.arg_as<uint32_t>() = files_.max_priority();
  return 0;
}

int VirtualV4l2Device::s_priority(Call& call) {
  return files_.set_priority(call.file, *call.arg_as<uint32_t>());
}

// Controls and control events.

int VirtualV4l2Device::queryctrl(Call& call) {
  return controls_.queryctrl(call.arg_as<v4l2_queryctrl>());
}

int VirtualV4l2Device::query_ext_ctrl(Call& call) {
  return controls_.query_ext_ctrl(call.arg_as<v4l2_query_ext_ctrl>());
}

int VirtualV4l2Device::querymenu(Call& call) {
  return controls_.querymenu(call.arg_as<v4l2_querymenu>());
}

int VirtualV4l2Device::old_ctrl(Call& call, unsigned long request) {
  auto* old = call.arg_as<v4l2_control>();
  v4l2_ext_control ext{};
  ext.id = old->id;
  ext.value = old->value;
  v4l2_ext_controls controls{};
  controls.which = V4L2_CTRL_WHICH_CUR_VAL;
  controls.count = 1;
  controls.controls = &ext;
  // The old ioctls know no control classes.
  const VirtualV4l2Controls::Control* c = controls_.find(old->id);
  if (!c || c->query.type == V4L2_CTRL_TYPE_CTRL_CLASS) return -EINVAL;
  const int error =
      request == VIDIOC_G_EXT_CTRLS ? controls_.get(&controls) : set_controls(call.file, &controls);
  if (error == 0) old->value = ext.value;
  return error;
}

int VirtualV4l2Device::g_ctrl(Call& call) { return old_ctrl(call, VIDIOC_G_EXT_CTRLS); }

int VirtualV4l2Device::s_ctrl(Call& call) { return old_ctrl(call, VIDIOC_S_EXT_CTRLS); }

int VirtualV4l2Device::g_ext_ctrls(Call& call) {
  return controls_.get(call.arg_as<v4l2_ext_controls>());
}

int VirtualV4l2Device::try_ext_ctrls(Call& call) {
  return controls_.try_set(call.arg_as<v4l2_ext_controls>());
}

int VirtualV4l2Device::s_ext_ctrls(Call& call) {
  return set_controls(call.file, call.arg_as<v4l2_ext_controls>());
}

int VirtualV4l2Device::set_controls(int file, v4l2_ext_controls* controls) {
  if (int error = controls_.check_request(VIDIOC_S_EXT_CTRLS, *controls)) return error;
  if (int busy = files_.check_priority(file)) return busy;
  // While streaming, a value waits for its frame (control_latency_frames), counted from
  // the first frame that has not started by the sensor's clock.
  const std::optional<uint64_t> next_frame =
      queue_.streaming()
          ? std::optional(clock_.first_unstarted(VirtualV4l2FrameClock::Clock::now()))
          : std::nullopt;
  return controls_.set(controls, next_frame, [&](uint32_t id, uint32_t changes, bool by_caller) {
    queue_control_event(id, changes, by_caller ? file : 0);
  });
}

void VirtualV4l2Device::queue_control_event(uint32_t id, uint32_t changes, int originator,
                                            int only_file) {
  if (!controls_.find(id)) return;
  files_.queue_control_event(controls_.event(id, changes), originator, only_file);
  signal_readiness();
  changed_.notify_all();
}

int VirtualV4l2Device::subscribe_event(Call& call) {
  auto* sub = call.arg_as<v4l2_event_subscription>();
  if (sub->type != V4L2_EVENT_CTRL) return -EINVAL;
  const VirtualV4l2Controls::Control* c = controls_.find(sub->id);
  if (!c) return -EINVAL;
  files_.subscribe(call.file, sub->id, sub->flags);
  // A control class has no value to report.
  if ((sub->flags & V4L2_EVENT_SUB_FL_SEND_INITIAL) && c->query.type != V4L2_CTRL_TYPE_CTRL_CLASS)
    queue_control_event(sub->id, V4L2_EVENT_CTRL_CH_VALUE | V4L2_EVENT_CTRL_CH_FLAGS, 0, call.file);
  return 0;
}

int VirtualV4l2Device::unsubscribe_event(Call& call) {
  return files_.unsubscribe(call.file, *call.arg_as<v4l2_event_subscription>());
}

int VirtualV4l2Device::dqevent(Call& call) {
  return files_.dqevent(call.file, call.arg_as<v4l2_event>());
}

// The buffer queue and the stream.

int VirtualV4l2Device::reqbufs(Call& call) {
  auto* request = call.arg_as<v4l2_requestbuffers>();
  if (int error = queue_.check_reqbufs(call.file, request)) return error;
  if (int busy = files_.check_priority(call.file)) return busy;
  return queue_.reqbufs(call.file, request, format_.sizeimage);
}

int VirtualV4l2Device::querybuf(Call& call) {
  return queue_.querybuf(call.arg_as<v4l2_buffer>(), format_.sizeimage);
}

int VirtualV4l2Device::qbuf(Call& call) {
  const int result =
      queue_.qbuf(call.file, call.arg_as<v4l2_buffer>(), call.dmabuf_fd, format_.sizeimage);
  signal_readiness();
  changed_.notify_all();  // the frame clock may be waiting for a buffer
  return result;
}

int VirtualV4l2Device::dqbuf(Call& call) {
  auto* buffer = call.arg_as<v4l2_buffer>();
  if (int error = queue_.check_dqbuf(call.file, *buffer)) return error;
  if (fail_dequeues_ > 0) {
    --fail_dequeues_;
    return -EIO;
  }
  while (!queue_.has_done()) {
    if (!queue_.streaming()) return -EINVAL;
    if (files_.nonblocking(call.file)) return -EAGAIN;
    changed_.wait(call.lock);
    if (unplugged_) return -ENODEV;
  }
  queue_.dqbuf(buffer);
  signal_readiness();
  return 0;
}

int VirtualV4l2Device::expbuf(Call& call) {
  // Anyone may export, not only the queue's owner (vb2_ioctl_expbuf).
  return queue_.expbuf(call.arg_as<v4l2_exportbuffer>());
}

int VirtualV4l2Device::streamon(Call& call) {
  if (*call.arg_as<int>() != V4L2_BUF_TYPE_VIDEO_CAPTURE) return -EINVAL;
  if (int error = queue_.check_owner(call.file)) return error;
  if (int busy = files_.check_priority(call.file)) return busy;
  const bool was_streaming = queue_.streaming();
  if (int error = queue_.streamon()) return error;
  if (was_streaming) return 0;
  clock_.restart_sequence();
  signal_readiness();
  changed_.notify_all();
  return 0;
}

int VirtualV4l2Device::streamoff(Call& call) {
  if (*call.arg_as<int>() != V4L2_BUF_TYPE_VIDEO_CAPTURE) return -EINVAL;
  if (int error = queue_.check_busy(call.file)) return error;
  if (int busy = files_.check_priority(call.file)) return busy;
  queue_.streamoff();
  controls_.apply_pending();  // no frame in flight any more
  signal_readiness();
  changed_.notify_all();
  return 0;
}

}  // namespace camlab::mock
