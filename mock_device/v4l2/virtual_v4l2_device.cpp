// VirtualV4l2Device: construction, open files, the ioctl table and dispatch, poll, and
// fault injection. The handlers are in virtual_v4l2_ioctls.cpp, the producer thread in
// virtual_v4l2_producer.cpp.
#include "mock_device/v4l2/virtual_v4l2_device.h"

#include <poll.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <string>

#include "base/log.h"

namespace camlab::mock {

Result<std::unique_ptr<VirtualV4l2Device>> VirtualV4l2Device::create(CameraSpec camera,
                                                                     SceneSpec scene,
                                                                     VirtualDeviceOptions options) {
  if (options.view < 0 || options.view >= scene.view_count)
    return make_error("out_of_range",
                      "view " + std::to_string(options.view) + " is not in the scene");
  auto renderer = Renderer::create(std::move(camera), std::move(scene));
  if (!renderer) return renderer.error();
  std::unique_ptr<VirtualV4l2Device> device(new VirtualV4l2Device(std::move(*renderer), options));
  return device;
}

VirtualV4l2Device::VirtualV4l2Device(Renderer renderer, VirtualDeviceOptions options)
    : renderer_(std::move(renderer)),
      options_(options),
      controls_(renderer_.camera().controls, renderer_.camera().timing.control_latency_frames),
      clock_(renderer_.camera().timing.frame_interval_us, options_.realtime),
      formats_(offered_formats(renderer_.camera().sensor)) {
  const SensorSpec& sensor = renderer_.camera().sensor;
  format_.width = static_cast<uint32_t>(sensor.width_px);
  format_.height = static_cast<uint32_t>(sensor.height_px);
  format_.pixelformat = default_fourcc(sensor);
  v4l2_format f{};
  f.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  f.fmt.pix = format_;
  set_format(&f, true);
  if (options_.frame_grid_origin) clock_.set_grid(*options_.frame_grid_origin);
  producer_ = std::thread([this] { produce_frames(); });
}

VirtualV4l2Device::~VirtualV4l2Device() {
  {
    std::lock_guard lock(mutex_);
    stop_producer_ = true;
  }
  changed_.notify_all();
  producer_.join();
  // The queue's buffers are unmapped and closed by their owners.
}

int VirtualV4l2Device::open_file(bool nonblocking) {
  std::lock_guard lock(mutex_);
  if (unplugged_) return -ENODEV;
  return files_.add(nonblocking);
}

void VirtualV4l2Device::attach_eventfd(int file, int eventfd) {
  std::lock_guard lock(mutex_);
  if (!files_.contains(file)) return;
  files_.attach_eventfd(file, eventfd);
  signal_readiness();
}

void VirtualV4l2Device::signal_readiness() {
  files_.signal_readiness([this](int file) {
    return (poll_events_locked(file, POLLIN | POLLRDNORM) & (POLLIN | POLLERR)) != 0;
  });
}

void VirtualV4l2Device::close_file(int file) {
  std::lock_guard lock(mutex_);
  dead_files_.erase(file);
  queue_.release(file);
  files_.remove(file);
  signal_readiness();
  changed_.notify_all();
}

const VirtualV4l2Device::IoctlInfo* VirtualV4l2Device::find_ioctl(unsigned long request) {
  // As v4l2-ioctl.c's v4l2_ioctls[]: what the device answers, and the handler of each.
  static constexpr IoctlInfo kIoctls[] = {
      {VIDIOC_QUERYCAP, &VirtualV4l2Device::querycap},
      {VIDIOC_ENUM_FMT, &VirtualV4l2Device::enum_fmt},
      {VIDIOC_ENUM_FRAMESIZES, &VirtualV4l2Device::enum_framesizes},
      {VIDIOC_ENUM_FRAMEINTERVALS, &VirtualV4l2Device::enum_frameintervals},
      {VIDIOC_G_FMT, &VirtualV4l2Device::g_fmt},
      {VIDIOC_TRY_FMT, &VirtualV4l2Device::try_fmt},
      {VIDIOC_S_FMT, &VirtualV4l2Device::s_fmt},
      {VIDIOC_G_PARM, &VirtualV4l2Device::g_parm},
      {VIDIOC_S_PARM, &VirtualV4l2Device::s_parm},
      {VIDIOC_ENUMINPUT, &VirtualV4l2Device::enuminput},
      {VIDIOC_G_INPUT, &VirtualV4l2Device::g_input},
      {VIDIOC_S_INPUT, &VirtualV4l2Device::s_input},
      {VIDIOC_G_PRIORITY, &VirtualV4l2Device::g_priority},
      {VIDIOC_S_PRIORITY, &VirtualV4l2Device::s_priority},
      {VIDIOC_QUERYCTRL, &VirtualV4l2Device::queryctrl},
      {VIDIOC_QUERY_EXT_CTRL, &VirtualV4l2Device::query_ext_ctrl},
      {VIDIOC_QUERYMENU, &VirtualV4l2Device::querymenu},
      {VIDIOC_G_CTRL, &VirtualV4l2Device::g_ctrl},
      {VIDIOC_S_CTRL, &VirtualV4l2Device::s_ctrl},
      {VIDIOC_G_EXT_CTRLS, &VirtualV4l2Device::g_ext_ctrls},
      {VIDIOC_S_EXT_CTRLS, &VirtualV4l2Device::s_ext_ctrls},
      {VIDIOC_TRY_EXT_CTRLS, &VirtualV4l2Device::try_ext_ctrls},
      {VIDIOC_SUBSCRIBE_EVENT, &VirtualV4l2Device::subscribe_event},
      {VIDIOC_UNSUBSCRIBE_EVENT, &VirtualV4l2Device::unsubscribe_event},
      {VIDIOC_DQEVENT, &VirtualV4l2Device::dqevent},
      {VIDIOC_REQBUFS, &VirtualV4l2Device::reqbufs},
      {VIDIOC_QUERYBUF, &VirtualV4l2Device::querybuf},
      {VIDIOC_QBUF, &VirtualV4l2Device::qbuf},
      {VIDIOC_DQBUF, &VirtualV4l2Device::dqbuf},
      {VIDIOC_EXPBUF, &VirtualV4l2Device::expbuf},
      {VIDIOC_STREAMON, &VirtualV4l2Device::streamon},
      {VIDIOC_STREAMOFF, &VirtualV4l2Device::streamoff},
  };
  for (const IoctlInfo& info : kIoctls)
    if (info.request == request) return &info;
  return nullptr;
}

bool VirtualV4l2Device::is_supported_ioctl(unsigned long request) {
  return find_ioctl(request) != nullptr;
}

int VirtualV4l2Device::ioctl(int file, unsigned long request, void* arg) {
  return ioctl(file, request, arg, -1);
}

int VirtualV4l2Device::ioctl(int file, unsigned long request, void* arg, int dmabuf_fd) {
  std::unique_lock lock(mutex_);
  if (unplugged_ || dead_files_.contains(file)) return -ENODEV;
  if (!files_.contains(file)) return -EBADF;
  // Unknown ioctls are ENOTTY before the argument is looked at, as in the kernel.
  const IoctlInfo* info = find_ioctl(request);
  if (info == nullptr) return -ENOTTY;
  if (arg == nullptr) return -EFAULT;
  Call call{file, arg, dmabuf_fd, lock};
  return (this->*(info->handler))(call);
}

short VirtualV4l2Device::poll_events(int file, short requested) {
  std::lock_guard lock(mutex_);
  return poll_events_locked(file, requested);
}

short VirtualV4l2Device::poll_events_locked(int file, short requested) const {
  if (unplugged_ || !files_.contains(file)) return POLLERR | POLLHUP;
  short events = 0;
  if (files_.has_events(file)) events |= POLLPRI;
  if (queue_.owner() == file || queue_.owner() == 0) {
    if (!queue_.streaming()) {
      if (requested & (POLLIN | POLLRDNORM)) events |= POLLERR;  // vb2: nothing will come
    } else if (queue_.has_done()) {
      events |= POLLIN | POLLRDNORM;
    }
  }
  return events & (requested | POLLERR | POLLHUP);
}

short VirtualV4l2Device::wait_events(int file, short requested, int timeout_ms) {
  std::unique_lock lock(mutex_);
  const auto deadline =
      std::chrono::steady_clock::now() + std::chrono::milliseconds(std::max(timeout_ms, 0));
  for (;;) {
    const short events = poll_events_locked(file, requested);
    if (events != 0 || timeout_ms == 0) return events;
    if (timeout_ms < 0) {
      changed_.wait(lock);
    } else if (changed_.wait_until(lock, deadline) == std::cv_status::timeout) {
      return poll_events_locked(file, requested);
    }
  }
}

int VirtualV4l2Device::buffer_for_mmap(off_t offset, size_t length, BufferMemory* out) {
  std::lock_guard lock(mutex_);
  if (unplugged_) return -ENODEV;
  return queue_.buffer_for_mmap(offset, length, out);
}

int VirtualV4l2Device::userptr_source(uint32_t index, BufferMemory* out) {
  std::lock_guard lock(mutex_);
  if (unplugged_) return -ENODEV;
  return queue_.userptr_source(index, out);
}

void VirtualV4l2Device::note_mapping(off_t offset, int delta) {
  std::lock_guard lock(mutex_);
  queue_.note_mapping(offset, delta);
}

void VirtualV4l2Device::unplug() {
  std::lock_guard lock(mutex_);
  unplugged_ = true;
  queue_.stop();
  signal_readiness();
  changed_.notify_all();
}

void VirtualV4l2Device::replug() {
  std::lock_guard lock(mutex_);
  if (!unplugged_) return;
  for (int file : files_.ids()) {
    dead_files_.insert(file);
    files_.remove(file);  // its priority and events went with the old device
  }
  // The producer renders with the mutex released and re-checks the queue before it
  // copies, so the old buffers can go now; their holders' mappings keep the memory.
  queue_ = VirtualV4l2Queue();
  controls_ = VirtualV4l2Controls(renderer_.camera().controls,
                                  renderer_.camera().timing.control_latency_frames);
  unplugged_ = false;
  changed_.notify_all();
}

bool VirtualV4l2Device::unplugged() const {
  std::lock_guard lock(mutex_);
  return unplugged_;
}

void VirtualV4l2Device::fail_next_dequeues(int count) {
  std::lock_guard lock(mutex_);
  fail_dequeues_ = count;
}

void VirtualV4l2Device::drop_next_frames(int count) {
  std::lock_guard lock(mutex_);
  clock_.drop_next_frames(count);
}

void VirtualV4l2Device::stall(bool stalled) {
  std::lock_guard lock(mutex_);
  clock_.stall(stalled);
  signal_readiness();
  changed_.notify_all();
}

Status VirtualV4l2Device::set_target_pose(const std::string& target, const RtCamTarget& pose) {
  std::lock_guard lock(mutex_);
  // The renderer's scene names never change, so checking against it here is safe while the
  // producer renders; the pose is checked the same way the renderer will check it.
  const auto& targets = renderer_.scene().targets;
  if (std::none_of(targets.begin(), targets.end(),
                   [&](const TargetSpec& t) { return t.name == target; })) {
    std::string names;
    for (const TargetSpec& t : targets) names += (names.empty() ? "" : ", ") + t.name;
    return make_error("not_found", "the scene has no target '" + target.substr(0, 60) +
                                       "' (it has: " + names + ")");
  }
  if (!(pose[5] > 0) ||
      !std::all_of(pose.begin(), pose.end(), [](double v) { return std::isfinite(v); }))
    return make_error("out_of_range",
                      "the target origin must be finite and in front of the camera (z > 0)");
  pending_target_moves_.emplace_back(target, pose);
  return {};
}

void VirtualV4l2Device::apply_target_moves() {
  if (pending_target_moves_.empty()) return;
  for (const auto& [target, pose] : pending_target_moves_)
    if (Status s = renderer_.set_target_pose(target, options_.view, pose); !s)
      log_warning(log::Category::kVcam, "cannot move target '%s': %s", target.c_str(),
                  s.error().message.c_str());
  pending_target_moves_.clear();
  prepared_.valid = false;  // frame 0 rendered ahead shows the old pose
}

}  // namespace camlab::mock
