// VirtualV4l2Device: the buffer queue (REQBUFS, QUERYBUF, QBUF, DQBUF, STREAMON,
// STREAMOFF, EXPBUF) with videobuf2's rules, MMAP buffers in memfds (exported as new
// fds of the memfd), DMABUF buffers imported by mapping the client's fd, and the frame
// clock that renders into queued buffers.
#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>

#include <opencv2/imgproc.hpp>

#include "mock_device/v4l2/virtual_v4l2_device.h"
#include "base/log.h"
#include "mock_device/render/sensor_model.h"
#include "optics/optics.h"

namespace camlab::mock {

namespace {

constexpr uint32_t kMaxBuffers = 32;  // VB2_MAX_FRAME

size_t page_align(size_t bytes) {
  const size_t page = static_cast<size_t>(sysconf(_SC_PAGESIZE));
  return (bytes + page - 1) / page * page;
}

}  // namespace

void VirtualV4l2Device::free_buffers() {
  for (auto& b : buffers_) {
    if (b.address) munmap(b.address, b.length);
    if (b.memfd >= 0) close(b.memfd);
  }
  buffers_.clear();
  ++buffers_generation_;  // a frame being rendered must not write into freed memory
  queued_order_.clear();
  done_order_.clear();
  buffer_stride_ = 0;
}

int VirtualV4l2Device::reqbufs(int file, v4l2_requestbuffers* request) {
  if (request->type != V4L2_BUF_TYPE_VIDEO_CAPTURE) return -EINVAL;
  // The same capabilities whatever memory is asked for (v4l2-compliance checks it).
  request->capabilities = V4L2_BUF_CAP_SUPPORTS_MMAP | V4L2_BUF_CAP_SUPPORTS_DMABUF;
  request->flags = 0;  // no cache hints: V4L2_MEMORY_FLAG_NON_COHERENT is not supported
  std::memset(request->reserved, 0, sizeof request->reserved);
  if (request->memory != V4L2_MEMORY_MMAP && request->memory != V4L2_MEMORY_DMABUF) return -EINVAL;
  if (queue_owner_ != 0 && queue_owner_ != file) return -EBUSY;
  if (int busy = check_priority(file)) return busy;
  if (streaming_) return -EBUSY;
  for (const auto& b : buffers_)
    if (b.mappings > 0) return -EBUSY;  // vb2: buffers still mapped by the client
  free_buffers();
  if (request->count == 0) {
    queue_owner_ = 0;
    return 0;
  }
  const uint32_t count = std::clamp<uint32_t>(request->count, 2, kMaxBuffers);
  memory_ = static_cast<v4l2_memory>(request->memory);
  if (memory_ == V4L2_MEMORY_DMABUF) {
    // No memory of our own: each QBUF brings the buffer (import_dmabuf).
    buffers_.assign(count, Buffer{});
    for (auto& b : buffers_) b.dmabuf_length = format_.sizeimage;
    request->count = count;
    queue_owner_ = file;
    return 0;
  }
  const size_t length = page_align(format_.sizeimage);
  for (uint32_t i = 0; i < count; ++i) {
    Buffer b;
    b.memfd = memfd_create("camlab-vcam-buffer", MFD_CLOEXEC);
    if (b.memfd < 0 || ftruncate(b.memfd, static_cast<off_t>(length)) != 0) {
      const int err = errno;
      if (b.memfd >= 0) close(b.memfd);
      free_buffers();
      return -(err ? err : ENOMEM);
    }
    b.length = length;
    b.address = static_cast<uint8_t*>(mmap(nullptr, length, PROT_READ | PROT_WRITE, MAP_SHARED, b.memfd, 0));
    if (b.address == MAP_FAILED) {
      b.address = nullptr;
      close(b.memfd);
      free_buffers();
      return -ENOMEM;
    }
    buffers_.push_back(b);
  }
  buffer_stride_ = length;
  request->count = count;
  queue_owner_ = file;
  return 0;
}

int VirtualV4l2Device::querybuf(v4l2_buffer* buffer) const {
  if (buffer->type != V4L2_BUF_TYPE_VIDEO_CAPTURE) return -EINVAL;
  if (buffer->index >= buffers_.size()) return -EINVAL;
  const Buffer& b = buffers_[buffer->index];
  const uint32_t index = buffer->index;
  if (b.state == Buffer::State::kDone) {
    *buffer = b.done;
  } else {
    std::memset(buffer, 0, sizeof *buffer);
    buffer->index = index;
    buffer->type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    buffer->field = V4L2_FIELD_NONE;
  }
  buffer->memory = memory_;
  if (memory_ == V4L2_MEMORY_DMABUF) {
    buffer->m.fd = b.user_fd;
    buffer->length = b.dmabuf_length;
  } else {
    buffer->m.offset = static_cast<uint32_t>(index * buffer_stride_);
    buffer->length = static_cast<uint32_t>(format_.sizeimage);
  }
  buffer->flags = (buffer->flags & ~(V4L2_BUF_FLAG_QUEUED | V4L2_BUF_FLAG_DONE | V4L2_BUF_FLAG_MAPPED)) |
                  V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC | V4L2_BUF_FLAG_TSTAMP_SRC_SOE;
  if (b.state == Buffer::State::kQueued || b.state == Buffer::State::kFilling) buffer->flags |= V4L2_BUF_FLAG_QUEUED;
  if (b.state == Buffer::State::kDone) buffer->flags |= V4L2_BUF_FLAG_DONE;
  if (b.mappings > 0) buffer->flags |= V4L2_BUF_FLAG_MAPPED;
  return 0;
}

int VirtualV4l2Device::qbuf(int file, v4l2_buffer* buffer, int dmabuf_fd) {
  if (buffer->type != V4L2_BUF_TYPE_VIDEO_CAPTURE || buffer->memory != memory_) return -EINVAL;
  if (queue_owner_ != file) return queue_owner_ == 0 ? -EINVAL : -EBUSY;
  if (buffer->index >= buffers_.size()) return -EINVAL;
  Buffer& b = buffers_[buffer->index];
  if (b.state != Buffer::State::kDequeued) return -EINVAL;
  if (memory_ == V4L2_MEMORY_DMABUF) {
    if (int error = import_dmabuf(b, dmabuf_fd >= 0 ? dmabuf_fd : buffer->m.fd, buffer->length); error < 0)
      return error;
    b.user_fd = buffer->m.fd;
  }
  b.state = Buffer::State::kQueued;
  queued_order_.push_back(static_cast<int>(buffer->index));
  buffer->flags &= ~(V4L2_BUF_FLAG_NO_CACHE_INVALIDATE | V4L2_BUF_FLAG_NO_CACHE_CLEAN);
  return querybuf(buffer);
}

int VirtualV4l2Device::dqbuf(int file, v4l2_buffer* buffer, std::unique_lock<std::mutex>& lock) {
  if (buffer->type != V4L2_BUF_TYPE_VIDEO_CAPTURE || buffer->memory != memory_) return -EINVAL;
  if (queue_owner_ != file) return queue_owner_ == 0 ? -EINVAL : -EBUSY;
  if (fail_dequeues_ > 0) {
    --fail_dequeues_;
    return -EIO;
  }
  while (done_order_.empty()) {
    if (!streaming_) return -EINVAL;
    if (files_[file].nonblocking) return -EAGAIN;
    changed_.wait(lock);
    if (unplugged_) return -ENODEV;
  }
  const int index = done_order_.front();
  done_order_.pop_front();
  Buffer& b = buffers_[static_cast<size_t>(index)];
  *buffer = b.done;
  b.state = Buffer::State::kDequeued;
  signal_readiness();
  buffer->memory = memory_;
  if (memory_ == V4L2_MEMORY_DMABUF) {
    buffer->m.fd = b.user_fd;
    buffer->length = b.dmabuf_length;
  } else {
    buffer->m.offset = static_cast<uint32_t>(static_cast<size_t>(index) * buffer_stride_);
  }
  buffer->flags &= ~(V4L2_BUF_FLAG_QUEUED | V4L2_BUF_FLAG_DONE);
  if (b.mappings > 0) buffer->flags |= V4L2_BUF_FLAG_MAPPED;
  return 0;
}

int VirtualV4l2Device::streamon(int file) {
  if (queue_owner_ != file) return queue_owner_ == 0 ? -EINVAL : -EBUSY;
  if (int busy = check_priority(file)) return busy;
  if (buffers_.empty()) return -EINVAL;
  if (streaming_) return 0;
  streaming_ = true;
  next_sequence_ = 0;
  signal_readiness();
  changed_.notify_all();
  return 0;
}

int VirtualV4l2Device::streamoff(int file) {
  if (queue_owner_ != 0 && queue_owner_ != file) return -EBUSY;
  if (int busy = check_priority(file)) return busy;
  streaming_ = false;
  // vb2 returns every buffer to the application, done or not.
  for (auto& b : buffers_) b.state = Buffer::State::kDequeued;
  queued_order_.clear();
  done_order_.clear();
  for (const auto& p : pending_) in_effect_[p.id] = p.value;  // no frame in flight any more
  pending_.clear();
  signal_readiness();
  changed_.notify_all();
  return 0;
}

int VirtualV4l2Device::import_dmabuf(Buffer& b, int fd, uint32_t asked_length) {
  // As vb2's __prepare_dmabuf: a length of 0 means the whole buffer; less than the
  // format's sizeimage is EINVAL, more than the buffer has is EFAULT (attach_dmabuf).
  struct stat st {};
  if (fd < 0 || fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) return -EINVAL;  // not a buffer fd
  const auto size = static_cast<size_t>(st.st_size);
  const size_t length = asked_length ? asked_length : size;
  if (length < format_.sizeimage) return -EINVAL;
  if (size < length) return -EFAULT;
  // The same buffer queued again keeps its mapping (as vb2 keeps the attachment).
  if (b.address && b.import_device == st.st_dev && b.import_inode == st.st_ino && b.length >= length) {
    b.dmabuf_length = static_cast<uint32_t>(length);
    return 0;
  }
  void* address = mmap(nullptr, length, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
  if (address == MAP_FAILED) return -EINVAL;
  if (b.address) munmap(b.address, b.length);
  b.address = static_cast<uint8_t*>(address);
  b.length = length;
  b.import_device = st.st_dev;
  b.import_inode = st.st_ino;
  b.dmabuf_length = static_cast<uint32_t>(length);
  return 0;
}

int VirtualV4l2Device::expbuf(v4l2_exportbuffer* exported) const {
  // vb2_core_expbuf's checks, in its order.
  if (exported->flags & ~(O_CLOEXEC | O_ACCMODE)) return -EINVAL;
  if (exported->type != V4L2_BUF_TYPE_VIDEO_CAPTURE || memory_ != V4L2_MEMORY_MMAP) return -EINVAL;
  if (exported->index >= buffers_.size() || exported->plane != 0) return -EINVAL;
  const int memfd = buffers_[exported->index].memfd;
  // A new open file description of the memfd, so the access mode asked for holds; a dup
  // (same description) only if /proc is not mounted.
  const std::string self = "/proc/self/fd/" + std::to_string(memfd);
  int fd = open(self.c_str(), static_cast<int>(exported->flags & (O_CLOEXEC | O_ACCMODE)));
  if (fd < 0) fd = fcntl(memfd, (exported->flags & O_CLOEXEC) ? F_DUPFD_CLOEXEC : F_DUPFD, 0);
  if (fd < 0) return -errno;
  exported->fd = fd;
  std::memset(exported->reserved, 0, sizeof exported->reserved);
  return 0;
}

int VirtualV4l2Device::buffer_for_mmap(off_t offset, size_t length, BufferMemory* out) {
  std::lock_guard lock(mutex_);
  if (unplugged_) return -ENODEV;
  if (memory_ != V4L2_MEMORY_MMAP) return -EINVAL;  // imported buffers are mapped through their own fd
  if (buffer_stride_ == 0 || offset < 0 || static_cast<size_t>(offset) % buffer_stride_ != 0) return -EINVAL;
  const size_t index = static_cast<size_t>(offset) / buffer_stride_;
  if (index >= buffers_.size() || length == 0 || length > buffers_[index].length) return -EINVAL;
  *out = {buffers_[index].memfd, buffers_[index].address, buffers_[index].length};
  return 0;
}

void VirtualV4l2Device::note_mapping(off_t offset, int delta) {
  std::lock_guard lock(mutex_);
  if (buffer_stride_ == 0) return;
  const size_t index = static_cast<size_t>(offset) / buffer_stride_;
  if (index < buffers_.size()) buffers_[index].mappings = std::max(0, buffers_[index].mappings + delta);
}

RenderSettings VirtualV4l2Device::settings_in_effect() const {
  const CameraSpec& camera = renderer_.camera();
  RenderSettings s;
  s.gain = static_cast<double>(in_effect_.at(V4L2_CID_GAIN)) / camera.controls.gain_unity;
  s.f_number = camera.lens.iris.f_numbers[static_cast<size_t>(in_effect_.at(V4L2_CID_IRIS_ABSOLUTE))];
  s.focus_position = static_cast<int>(in_effect_.at(V4L2_CID_FOCUS_ABSOLUTE));
  if (in_effect_.at(V4L2_CID_FOCUS_AUTO) != 0 && !renderer_.scene().targets.empty()) {
    // Autofocus: on the first target's distance, to the nearest motor step.
    const auto& target = renderer_.scene().targets.front();
    const double distance_mm = renderer_.scene().pose(target, options_.view)[5] * 1e3;
    auto z_s = optics::lens_to_sensor_mm(camera.lens.focal_mm, distance_mm);
    if (z_s)
      s.focus_position = std::clamp(
          static_cast<int>(std::lround((*z_s - camera.lens.focal_mm) / camera.lens.focus.extension_mm_per_step)),
          camera.lens.focus.position_min, camera.lens.focus.position_max);
  }
  const ControlRange& range = camera.controls.exposure_time_absolute;
  if (in_effect_.at(V4L2_CID_EXPOSURE_AUTO) != V4L2_EXPOSURE_MANUAL) {
    // Aperture priority: put a mid-grey (18% reflectance) at 18% of the DN range.
    const double lens_to_sensor_mm = camera.lens.focal_mm + s.focus_position * camera.lens.focus.extension_mm_per_step;
    const double e_per_us = electrons_per_unit_reflectance(camera, renderer_.scene().illuminance_lux, 1.0,
                                                           s.f_number, lens_to_sensor_mm);
    const double range_dn = (1 << camera.sensor.bit_depth) - 1 - camera.sensor.black_level_dn;
    const double t_us = range_dn / (e_per_us * camera.sensor.conversion_gain_dn_per_e * s.gain);
    s.exposure_us = std::clamp(t_us, range.min * 100.0, range.max * 100.0);
  } else {
    s.exposure_us = static_cast<double>(in_effect_.at(V4L2_CID_EXPOSURE_ABSOLUTE)) * 100.0;
  }
  return s;
}

bool VirtualV4l2Device::render_into(int index, uint64_t sequence, std::unique_lock<std::mutex>& lock,
                                    bool* failed) {
  *failed = false;
  const RenderSettings settings = settings_in_effect();
  const v4l2_pix_format format = format_;
  RenderOptions options;
  options.seed = options_.seed;
  options.frame_number = sequence;
  const int bit_depth = renderer_.camera().sensor.bit_depth;
  const uint64_t generation = buffers_generation_;
  // Render without the lock: ioctls (controls, status) must not wait on a frame.
  lock.unlock();
  auto frame = renderer_.render(settings, options_.view, options);
  cv::Mat dn;
  if (frame) {
    frame->image.convertTo(dn, CV_32F);
    if (dn.cols != static_cast<int>(format.width) || dn.rows != static_cast<int>(format.height))
      cv::resize(dn, dn, cv::Size(static_cast<int>(format.width), static_cast<int>(format.height)), 0, 0,
                 cv::INTER_AREA);  // 2x2 binning
  }
  lock.lock();
  // The stream may have stopped, or the buffers been freed, while the frame rendered.
  if (generation != buffers_generation_ || !streaming_) return false;
  Buffer& buffer = buffers_[static_cast<size_t>(index)];
  if (buffer.state != Buffer::State::kFilling) return false;
  if (!frame) {
    // A driver that cannot fill a buffer returns it flagged, never keeps it: the client
    // sees V4L2_BUF_FLAG_ERROR instead of waiting forever.
    if (!render_error_reported_) {
      log_warning(log::Category::kVcam, "cannot render frame %llu: %s",
                  static_cast<unsigned long long>(sequence), frame.error().message.c_str());
      render_error_reported_ = true;  // a repeating error is logged once
    }
    std::memset(buffer.address, 0, format.sizeimage);
    *failed = true;
    return true;
  }
  uint8_t* out = buffer.address;
  for (uint32_t y = 0; y < format.height; ++y) {
    const float* row = dn.ptr<float>(static_cast<int>(y));
    uint8_t* line = out + static_cast<size_t>(y) * format.bytesperline;
    for (uint32_t x = 0; x < format.width; ++x) {
      const float v = row[x];
      if (format.pixelformat == V4L2_PIX_FMT_Y16) {
        // Y16 carries the DN scaled to the full 16 bits (MSB-aligned), little endian.
        const auto value = static_cast<uint16_t>(std::lround(std::ldexp(v, 16 - bit_depth)));
        line[2 * x] = static_cast<uint8_t>(value & 0xff);
        line[2 * x + 1] = static_cast<uint8_t>(value >> 8);
      } else {
        const auto y8 = static_cast<uint8_t>(std::clamp(std::lround(std::ldexp(v, 8 - bit_depth)), 0L, 255L));
        if (format.pixelformat == V4L2_PIX_FMT_GREY) {
          line[x] = y8;
        } else {  // YUYV: grey, so U = V = 128
          line[2 * x] = y8;
          line[2 * x + 1] = 128;
        }
      }
    }
  }
  return true;
}

void VirtualV4l2Device::produce_frames() {
  std::unique_lock lock(mutex_);
  using clock = std::chrono::steady_clock;
  clock::time_point next_tick{};
  bool was_streaming = false;
  while (!stop_producer_) {
    if (!streaming_ || stalled_ || unplugged_) {
      was_streaming = false;
      changed_.wait(lock);
      continue;
    }
    const auto interval = std::chrono::microseconds(
        static_cast<int64_t>(1e6 * time_per_frame_.numerator / std::max<uint32_t>(time_per_frame_.denominator, 1)));
    if (!was_streaming) {
      // The scene integral for the settings in effect is the slow part of a first frame;
      // computing it before the clock starts keeps it from costing the first ticks.
      const RenderSettings settings = settings_in_effect();
      RenderOptions options;
      options.seed = options_.seed;
      lock.unlock();
      (void)renderer_.render(settings, options_.view, options);
      lock.lock();
      next_tick = clock::now();
      was_streaming = true;
      continue;  // re-check the stream state after the unlocked render
    }
    if (!options_.realtime && queued_order_.empty() && drop_frames_ == 0) {
      // As fast as rendered, but a frame is only started when a buffer waits for it.
      changed_.wait(lock);
      continue;
    }
    if (options_.realtime) {
      if (changed_.wait_until(lock, next_tick, [&] { return stop_producer_ || !streaming_ || stalled_; })) continue;
      next_tick += interval;
      // A frame that took longer than the interval to render costs ticks, as a sensor
      // that cannot keep up would: the skipped ticks show as sequence gaps.
      while (next_tick + interval < clock::now()) {
        next_tick += interval;
        ++next_sequence_;
      }
    }
    const uint64_t sequence = next_sequence_++;
    // Control values whose latency has passed reach the sensor with this frame.
    for (auto it = pending_.begin(); it != pending_.end();) {
      if (it->apply_at_sequence <= sequence) {
        in_effect_[it->id] = it->value;
        it = pending_.erase(it);
      } else {
        ++it;
      }
    }
    if (drop_frames_ > 0) {
      --drop_frames_;
      continue;
    }
    if (queued_order_.empty()) continue;  // no buffer: the frame is lost, its number too
    const int index = queued_order_.front();
    queued_order_.pop_front();
    buffers_[static_cast<size_t>(index)].state = Buffer::State::kFilling;
    timespec start{};
    clock_gettime(CLOCK_MONOTONIC, &start);
    bool failed = false;
    if (!render_into(index, sequence, lock, &failed)) continue;  // stream stopped meanwhile
    Buffer& buffer = buffers_[static_cast<size_t>(index)];
    v4l2_buffer& done = buffer.done;
    std::memset(&done, 0, sizeof done);
    done.index = static_cast<uint32_t>(index);
    done.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    done.bytesused = format_.sizeimage;
    done.flags = V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC | V4L2_BUF_FLAG_TSTAMP_SRC_SOE |
                 (failed ? V4L2_BUF_FLAG_ERROR : 0u);
    done.field = V4L2_FIELD_NONE;
    done.timestamp.tv_sec = start.tv_sec;
    done.timestamp.tv_usec = start.tv_nsec / 1000;
    done.sequence = static_cast<uint32_t>(sequence);
    done.memory = memory_;
    done.length = memory_ == V4L2_MEMORY_DMABUF ? buffer.dmabuf_length : format_.sizeimage;
    buffer.state = Buffer::State::kDone;
    done_order_.push_back(index);
    signal_readiness();
  changed_.notify_all();
  }
}

}  // namespace camlab::mock
