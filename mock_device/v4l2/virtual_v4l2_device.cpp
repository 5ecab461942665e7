// VirtualV4l2Device: construction, formats, capabilities, inputs, priorities, and the
// ioctl dispatch. Controls are in virtual_v4l2_controls.cpp, the buffer queue and the
// frame clock in virtual_v4l2_queue.cpp.
#include "mock_device/v4l2/virtual_v4l2_device.h"

#include <poll.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>

namespace camlab::mock {

namespace {

constexpr uint32_t kFormats[] = {V4L2_PIX_FMT_GREY, V4L2_PIX_FMT_Y16, V4L2_PIX_FMT_YUYV};
const char* const kFormatNames[] = {"8-bit Greyscale", "16-bit Greyscale", "YUYV 4:2:2"};

uint32_t bytes_per_pixel(uint32_t fourcc) { return fourcc == V4L2_PIX_FMT_GREY ? 1 : 2; }

void copy_string(uint8_t* dst, size_t size, const std::string& src) {
  std::memset(dst, 0, size);
  std::memcpy(dst, src.data(), std::min(size - 1, src.size()));
}

}  // namespace

Result<std::unique_ptr<VirtualV4l2Device>> VirtualV4l2Device::create(CameraSpec camera, SceneSpec scene,
                                                                      VirtualDeviceOptions options) {
  if (options.view < 0 || options.view >= scene.view_count)
    return make_error("out_of_range", "view " + std::to_string(options.view) + " is not in the scene");
  auto renderer = Renderer::create(std::move(camera), std::move(scene));
  if (!renderer) return renderer.error();
  std::unique_ptr<VirtualV4l2Device> device(new VirtualV4l2Device(std::move(*renderer), options));
  return device;
}

VirtualV4l2Device::VirtualV4l2Device(Renderer renderer, VirtualDeviceOptions options)
    : renderer_(std::move(renderer)), options_(options) {
  const SensorSpec& sensor = renderer_.camera().sensor;
  format_.width = static_cast<uint32_t>(sensor.width_px);
  format_.height = static_cast<uint32_t>(sensor.height_px);
  format_.pixelformat = sensor.bit_depth > 8 ? V4L2_PIX_FMT_Y16 : V4L2_PIX_FMT_GREY;
  v4l2_format f{};
  f.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  f.fmt.pix = format_;
  set_format(&f, true);
  time_per_frame_ = {static_cast<uint32_t>(std::lround(renderer_.camera().timing.frame_interval_us)), 1000000};
  add_controls();
  producer_ = std::thread([this] { produce_frames(); });
}

VirtualV4l2Device::~VirtualV4l2Device() {
  {
    std::lock_guard lock(mutex_);
    stop_producer_ = true;
  }
  changed_.notify_all();
  producer_.join();
  free_buffers();
}

int VirtualV4l2Device::open_file(bool nonblocking) {
  std::lock_guard lock(mutex_);
  if (unplugged_) return -ENODEV;
  const int id = next_file_++;
  files_[id].nonblocking = nonblocking;
  return id;
}

void VirtualV4l2Device::attach_eventfd(int file, int eventfd) {
  std::lock_guard lock(mutex_);
  auto it = files_.find(file);
  if (it == files_.end()) return;
  it->second.eventfd = eventfd;
  it->second.signalled = false;
  signal_readiness();
}

void VirtualV4l2Device::signal_readiness() {
  for (auto& [id, f] : files_) {
    if (f.eventfd < 0) continue;
    const bool ready = (poll_events(id, POLLIN | POLLRDNORM) & (POLLIN | POLLERR)) != 0;
    if (ready == f.signalled) continue;
    uint64_t count = 1;
    // The eventfd is non-blocking: write sets it readable, read drains it.
    const ssize_t n = ready ? ::write(f.eventfd, &count, sizeof count) : ::read(f.eventfd, &count, sizeof count);
    if (n == sizeof count) f.signalled = ready;
  }
}

void VirtualV4l2Device::close_file(int file) {
  std::lock_guard lock(mutex_);
  // The queue's owner closing the device stops the stream and frees unmapped buffers,
  // as videobuf2's release does.
  if (queue_owner_ == file) {
    streaming_ = false;
    for (auto& b : buffers_) b.state = Buffer::State::kDequeued;
    bool mapped = false;
    for (const auto& b : buffers_) mapped |= b.mappings > 0;
    if (!mapped) free_buffers();
    queue_owner_ = 0;
  }
  files_.erase(file);
  signal_readiness();
  changed_.notify_all();
}

v4l2_priority VirtualV4l2Device::max_priority() const {
  v4l2_priority highest = V4L2_PRIORITY_BACKGROUND;
  for (const auto& [id, f] : files_) highest = std::max(highest, f.priority);
  return highest;
}

int VirtualV4l2Device::check_priority(int file) const {
  auto it = files_.find(file);
  return it != files_.end() && it->second.priority < max_priority() ? -EBUSY : 0;
}

int VirtualV4l2Device::set_format(v4l2_format* format, bool apply) {
  if (format->type != V4L2_BUF_TYPE_VIDEO_CAPTURE) return -EINVAL;
  v4l2_pix_format& pix = format->fmt.pix;
  const SensorSpec& sensor = renderer_.camera().sensor;
  if (std::find(std::begin(kFormats), std::end(kFormats), pix.pixelformat) == std::end(kFormats))
    pix.pixelformat = sensor.bit_depth > 8 ? V4L2_PIX_FMT_Y16 : V4L2_PIX_FMT_GREY;
  // Two sizes: the full sensor, and 2x2 binned. Pick the nearer by area.
  const uint32_t full_w = sensor.width_px, full_h = sensor.height_px;
  const double asked = static_cast<double>(pix.width) * pix.height;
  const bool binned = asked > 0 && std::abs(asked - full_w * full_h / 4.0) < std::abs(asked - full_w * full_h);
  pix.width = binned ? full_w / 2 : full_w;
  pix.height = binned ? full_h / 2 : full_h;
  if (pix.pixelformat == V4L2_PIX_FMT_YUYV) pix.width &= ~1u;  // YUYV pairs pixels
  pix.field = V4L2_FIELD_NONE;
  pix.bytesperline = pix.width * bytes_per_pixel(pix.pixelformat);
  pix.sizeimage = pix.bytesperline * pix.height;
  pix.colorspace = V4L2_COLORSPACE_RAW;
  pix.priv = 0;
  pix.flags = 0;
  pix.ycbcr_enc = V4L2_YCBCR_ENC_DEFAULT;
  pix.quantization = V4L2_QUANTIZATION_DEFAULT;
  pix.xfer_func = V4L2_XFER_FUNC_NONE;
  if (pix.pixelformat == V4L2_PIX_FMT_YUYV) {
    pix.colorspace = V4L2_COLORSPACE_SRGB;
    pix.xfer_func = V4L2_XFER_FUNC_DEFAULT;
  }
  if (apply) format_ = pix;
  return 0;
}

bool VirtualV4l2Device::is_supported_ioctl(unsigned long request) {
  switch (request) {
    case VIDIOC_QUERYCAP: case VIDIOC_ENUM_FMT: case VIDIOC_ENUM_FRAMESIZES: case VIDIOC_ENUM_FRAMEINTERVALS:
    case VIDIOC_G_FMT: case VIDIOC_TRY_FMT: case VIDIOC_S_FMT: case VIDIOC_G_PARM: case VIDIOC_S_PARM:
    case VIDIOC_ENUMINPUT: case VIDIOC_G_INPUT: case VIDIOC_S_INPUT: case VIDIOC_G_PRIORITY:
    case VIDIOC_S_PRIORITY: case VIDIOC_QUERYCTRL: case VIDIOC_QUERY_EXT_CTRL: case VIDIOC_QUERYMENU:
    case VIDIOC_G_CTRL: case VIDIOC_S_CTRL: case VIDIOC_G_EXT_CTRLS: case VIDIOC_S_EXT_CTRLS:
    case VIDIOC_TRY_EXT_CTRLS: case VIDIOC_SUBSCRIBE_EVENT: case VIDIOC_UNSUBSCRIBE_EVENT:
    case VIDIOC_DQEVENT: case VIDIOC_REQBUFS: case VIDIOC_QUERYBUF: case VIDIOC_QBUF: case VIDIOC_DQBUF:
    case VIDIOC_STREAMON: case VIDIOC_STREAMOFF: case VIDIOC_EXPBUF:
      return true;
    default:
      return false;
  }
}

int VirtualV4l2Device::ioctl(int file, unsigned long request, void* arg) { return ioctl(file, request, arg, -1); }

int VirtualV4l2Device::ioctl(int file, unsigned long request, void* arg, int dmabuf_fd) {
  std::unique_lock lock(mutex_);
  if (unplugged_) return -ENODEV;
  if (files_.find(file) == files_.end()) return -EBADF;
  if (!is_supported_ioctl(request)) return -ENOTTY;
  if (arg == nullptr) return -EFAULT;
  const CameraSpec& camera = renderer_.camera();
  switch (request) {
    case VIDIOC_QUERYCAP: {
      auto* cap = static_cast<v4l2_capability*>(arg);
      std::memset(cap, 0, sizeof *cap);
      copy_string(cap->driver, sizeof cap->driver, "camlab-vcam");
      copy_string(cap->card, sizeof cap->card, camera.name);
      copy_string(cap->bus_info, sizeof cap->bus_info, "platform:camlab-vcam-" + std::to_string(options_.index));
      cap->version = (6u << 16) | (1u << 8);
      cap->device_caps = V4L2_CAP_VIDEO_CAPTURE | V4L2_CAP_STREAMING | V4L2_CAP_EXT_PIX_FORMAT;
      cap->capabilities = cap->device_caps | V4L2_CAP_DEVICE_CAPS;
      return 0;
    }
    case VIDIOC_ENUM_FMT: {
      auto* desc = static_cast<v4l2_fmtdesc*>(arg);
      if (desc->type != V4L2_BUF_TYPE_VIDEO_CAPTURE || desc->index >= std::size(kFormats)) return -EINVAL;
      const uint32_t index = desc->index;
      std::memset(desc, 0, sizeof *desc);
      desc->index = index;
      desc->type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
      desc->pixelformat = kFormats[index];
      copy_string(desc->description, sizeof desc->description, kFormatNames[index]);
      return 0;
    }
    case VIDIOC_ENUM_FRAMESIZES: {
      auto* size = static_cast<v4l2_frmsizeenum*>(arg);
      if (std::find(std::begin(kFormats), std::end(kFormats), size->pixel_format) == std::end(kFormats) ||
          size->index > 1)
        return -EINVAL;
      const uint32_t index = size->index, fourcc = size->pixel_format;
      std::memset(size, 0, sizeof *size);
      size->index = index;
      size->pixel_format = fourcc;
      size->type = V4L2_FRMSIZE_TYPE_DISCRETE;
      size->discrete.width = static_cast<uint32_t>(camera.sensor.width_px) >> index;
      size->discrete.height = static_cast<uint32_t>(camera.sensor.height_px) >> index;
      if (fourcc == V4L2_PIX_FMT_YUYV) size->discrete.width &= ~1u;
      return 0;
    }
    case VIDIOC_ENUM_FRAMEINTERVALS: {
      auto* interval = static_cast<v4l2_frmivalenum*>(arg);
      std::memset(interval->reserved, 0, sizeof interval->reserved);
      bool size_ok = false;
      for (uint32_t shift = 0; shift < 2; ++shift) {
        uint32_t w = static_cast<uint32_t>(camera.sensor.width_px) >> shift;
        if (interval->pixel_format == V4L2_PIX_FMT_YUYV) w &= ~1u;
        size_ok |= interval->width == w && interval->height == (static_cast<uint32_t>(camera.sensor.height_px) >> shift);
      }
      if (!size_ok || interval->index > 1 ||
          std::find(std::begin(kFormats), std::end(kFormats), interval->pixel_format) == std::end(kFormats))
        return -EINVAL;
      interval->type = V4L2_FRMIVAL_TYPE_DISCRETE;
      // The sensor's frame interval, and twice it (for longer exposures).
      interval->discrete = {static_cast<uint32_t>(std::lround(camera.timing.frame_interval_us)) << interval->index,
                            1000000};
      return 0;
    }
    case VIDIOC_G_FMT: {
      auto* format = static_cast<v4l2_format*>(arg);
      if (format->type != V4L2_BUF_TYPE_VIDEO_CAPTURE) return -EINVAL;
      std::memset(&format->fmt, 0, sizeof format->fmt);
      format->fmt.pix = format_;
      return 0;
    }
    case VIDIOC_TRY_FMT:
      return set_format(static_cast<v4l2_format*>(arg), false);
    case VIDIOC_S_FMT: {
      if (int busy = check_priority(file)) return busy;
      if (!buffers_.empty() && queue_owner_ != 0) return -EBUSY;
      return set_format(static_cast<v4l2_format*>(arg), true);
    }
    case VIDIOC_G_PARM:
    case VIDIOC_S_PARM: {
      auto* parm = static_cast<v4l2_streamparm*>(arg);
      if (parm->type != V4L2_BUF_TYPE_VIDEO_CAPTURE) return -EINVAL;
      if (request == VIDIOC_S_PARM) {
        if (int busy = check_priority(file)) return busy;
        if (streaming_) return -EBUSY;
        const v4l2_fract asked = parm->parm.capture.timeperframe;
        const double base_s = camera.timing.frame_interval_us * 1e-6;
        const double asked_s = asked.denominator ? static_cast<double>(asked.numerator) / asked.denominator : base_s;
        const uint32_t multiple = asked_s > 1.5 * base_s ? 2 : 1;
        time_per_frame_ = {static_cast<uint32_t>(std::lround(camera.timing.frame_interval_us)) * multiple, 1000000};
      }
      std::memset(&parm->parm, 0, sizeof parm->parm);
      parm->parm.capture.capability = V4L2_CAP_TIMEPERFRAME;
      parm->parm.capture.timeperframe = time_per_frame_;
      parm->parm.capture.readbuffers = 0;
      return 0;
    }
    case VIDIOC_ENUMINPUT: {
      auto* input = static_cast<v4l2_input*>(arg);
      if (input->index != 0) return -EINVAL;
      std::memset(input, 0, sizeof *input);
      copy_string(input->name, sizeof input->name, "Camera");
      input->type = V4L2_INPUT_TYPE_CAMERA;
      return 0;
    }
    case VIDIOC_G_INPUT:
      *static_cast<int*>(arg) = 0;
      return 0;
    case VIDIOC_S_INPUT:
      if (int busy = check_priority(file)) return busy;
      return *static_cast<int*>(arg) == 0 ? 0 : -EINVAL;
    case VIDIOC_G_PRIORITY:
      // The priority of the device: the highest of any open file (v4l2_prio_max).
      *static_cast<uint32_t*>(arg) = max_priority();
      return 0;
    case VIDIOC_S_PRIORITY: {
      const uint32_t asked = *static_cast<uint32_t*>(arg);
      if (asked > V4L2_PRIORITY_RECORD || asked == V4L2_PRIORITY_UNSET) return -EINVAL;
      // Only a file at the device's highest priority may change priorities.
      if (int busy = check_priority(file)) return busy;
      files_[file].priority = static_cast<v4l2_priority>(asked);
      return 0;
    }
    case VIDIOC_QUERYCTRL:
    case VIDIOC_QUERY_EXT_CTRL:
    case VIDIOC_QUERYMENU:
    case VIDIOC_G_CTRL:
    case VIDIOC_S_CTRL:
    case VIDIOC_G_EXT_CTRLS:
    case VIDIOC_S_EXT_CTRLS:
    case VIDIOC_TRY_EXT_CTRLS:
    case VIDIOC_SUBSCRIBE_EVENT:
    case VIDIOC_UNSUBSCRIBE_EVENT:
    case VIDIOC_DQEVENT:
      return control_ioctl(file, request, arg);
    case VIDIOC_REQBUFS:
      return reqbufs(file, static_cast<v4l2_requestbuffers*>(arg));
    case VIDIOC_QUERYBUF:
      return querybuf(static_cast<v4l2_buffer*>(arg));
    case VIDIOC_QBUF:
    {
      const int result = qbuf(file, static_cast<v4l2_buffer*>(arg), dmabuf_fd);
      signal_readiness();
  changed_.notify_all();  // the frame clock may be waiting for a buffer
      return result;
    }
    case VIDIOC_DQBUF:
      return dqbuf(file, static_cast<v4l2_buffer*>(arg), lock);
    case VIDIOC_EXPBUF:
      // Anyone may export, not only the queue's owner (vb2_ioctl_expbuf).
      return expbuf(static_cast<v4l2_exportbuffer*>(arg));
    case VIDIOC_STREAMON:
      if (*static_cast<int*>(arg) != V4L2_BUF_TYPE_VIDEO_CAPTURE) return -EINVAL;
      return streamon(file);
    case VIDIOC_STREAMOFF:
      if (*static_cast<int*>(arg) != V4L2_BUF_TYPE_VIDEO_CAPTURE) return -EINVAL;
      return streamoff(file);
    default:
      return -ENOTTY;
  }
}

short VirtualV4l2Device::poll_events(int file, short requested) {
  auto it = files_.find(file);
  if (unplugged_ || it == files_.end()) return POLLERR | POLLHUP;
  short events = 0;
  if (!it->second.events.empty()) events |= POLLPRI;
  if (queue_owner_ == file || queue_owner_ == 0) {
    if (!streaming_) {
      if (requested & (POLLIN | POLLRDNORM)) events |= POLLERR;  // vb2: nothing will come
    } else {
      for (const auto& b : buffers_)
        if (b.state == Buffer::State::kDone) events |= POLLIN | POLLRDNORM;
    }
  }
  return events & (requested | POLLERR | POLLHUP);
}

short VirtualV4l2Device::wait_events(int file, short requested, int timeout_ms) {
  std::unique_lock lock(mutex_);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(std::max(timeout_ms, 0));
  for (;;) {
    const short events = poll_events(file, requested);
    if (events != 0 || timeout_ms == 0) return events;
    if (timeout_ms < 0) changed_.wait(lock);
    else if (changed_.wait_until(lock, deadline) == std::cv_status::timeout) return poll_events(file, requested);
  }
}

void VirtualV4l2Device::unplug() {
  std::lock_guard lock(mutex_);
  unplugged_ = true;
  streaming_ = false;
  signal_readiness();
  changed_.notify_all();
}

void VirtualV4l2Device::fail_next_dequeues(int count) {
  std::lock_guard lock(mutex_);
  fail_dequeues_ = count;
}

void VirtualV4l2Device::drop_next_frames(int count) {
  std::lock_guard lock(mutex_);
  drop_frames_ = count;
}

void VirtualV4l2Device::stall(bool stalled) {
  std::lock_guard lock(mutex_);
  stalled_ = stalled;
  signal_readiness();
  changed_.notify_all();
}

}  // namespace camlab::mock
