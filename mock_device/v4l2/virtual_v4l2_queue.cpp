#include "mock_device/v4l2/virtual_v4l2_queue.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <string>
#include <utility>

namespace camlab::mock {

namespace {

constexpr uint32_t kMaxBuffers = 32;  // VB2_MAX_FRAME

size_t page_align(size_t bytes) {
  const size_t page = static_cast<size_t>(sysconf(_SC_PAGESIZE));
  return (bytes + page - 1) / page * page;
}

}  // namespace

int VirtualV4l2Queue::check_busy(int file) const {
  return owner_ != 0 && owner_ != file ? -EBUSY : 0;
}

int VirtualV4l2Queue::check_owner(int file) const {
  if (owner_ != file) return owner_ == 0 ? -EINVAL : -EBUSY;
  return 0;
}

void VirtualV4l2Queue::free_buffers() {
  buffers_.clear();  // unmaps and closes
  ++generation_;     // a frame being rendered must not write into freed memory
  queued_order_.clear();
  done_order_.clear();
  stride_bytes_ = 0;
}

int VirtualV4l2Queue::check_reqbufs(int file, v4l2_requestbuffers* request) const {
  if (request->type != V4L2_BUF_TYPE_VIDEO_CAPTURE) return -EINVAL;
  // The same capabilities whatever memory is asked for (v4l2-compliance checks it).
  request->capabilities =
      V4L2_BUF_CAP_SUPPORTS_MMAP | V4L2_BUF_CAP_SUPPORTS_USERPTR | V4L2_BUF_CAP_SUPPORTS_DMABUF;
  request->flags = 0;  // no cache hints: V4L2_MEMORY_FLAG_NON_COHERENT is not supported
  std::memset(request->reserved, 0, sizeof request->reserved);
  if (request->memory != V4L2_MEMORY_MMAP && request->memory != V4L2_MEMORY_USERPTR &&
      request->memory != V4L2_MEMORY_DMABUF)
    return -EINVAL;
  return check_busy(file);
}

int VirtualV4l2Queue::reqbufs(int file, v4l2_requestbuffers* request, uint32_t sizeimage) {
  if (int error = check_reqbufs(file, request)) return error;
  if (streaming_) return -EBUSY;
  for (const auto& b : buffers_)
    if (b.mappings > 0) return -EBUSY;  // vb2: buffers still mapped by the client
  free_buffers();
  if (request->count == 0) {
    owner_ = 0;
    return 0;
  }
  const uint32_t count = std::clamp<uint32_t>(request->count, 2, kMaxBuffers);
  memory_ = static_cast<v4l2_memory>(request->memory);
  if (memory_ == V4L2_MEMORY_DMABUF) {
    // No memory of our own: each QBUF brings the buffer (import_dmabuf).
    buffers_.resize(count);
    for (auto& b : buffers_) b.dmabuf_length = sizeimage;
    request->count = count;
    owner_ = file;
    return 0;
  }
  const size_t length = page_align(sizeimage);
  buffers_.reserve(count);
  for (uint32_t i = 0; i < count; ++i) {
    Buffer b;
    b.memfd.reset(memfd_create("camlab-vcam-buffer", MFD_CLOEXEC));
    if (!b.memfd || ftruncate(b.memfd.get(), static_cast<off_t>(length)) != 0) {
      const int err = errno;
      free_buffers();
      return -(err ? err : ENOMEM);
    }
    b.mapping = MappedBuffer(
        mmap(nullptr, length, PROT_READ | PROT_WRITE, MAP_SHARED, b.memfd.get(), 0), length);
    if (!b.mapping) {
      free_buffers();
      return -ENOMEM;
    }
    b.user_length = sizeimage;  // vb2 reports the format's size until QBUF gives one
    buffers_.push_back(std::move(b));
  }
  stride_bytes_ = length;
  request->count = count;
  owner_ = file;
  return 0;
}

int VirtualV4l2Queue::querybuf(v4l2_buffer* buffer, uint32_t sizeimage) const {
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
  } else if (memory_ == V4L2_MEMORY_USERPTR) {
    buffer->m.userptr = b.user_pointer;
    buffer->length = b.user_length;
  } else {
    buffer->m.offset = static_cast<uint32_t>(index * stride_bytes_);
    buffer->length = sizeimage;
  }
  buffer->flags =
      (buffer->flags & ~(V4L2_BUF_FLAG_QUEUED | V4L2_BUF_FLAG_DONE | V4L2_BUF_FLAG_MAPPED)) |
      V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC | V4L2_BUF_FLAG_TSTAMP_SRC_SOE;
  if (b.state == Buffer::State::kQueued || b.state == Buffer::State::kFilling)
    buffer->flags |= V4L2_BUF_FLAG_QUEUED;
  if (b.state == Buffer::State::kDone) buffer->flags |= V4L2_BUF_FLAG_DONE;
  if (b.mappings > 0) buffer->flags |= V4L2_BUF_FLAG_MAPPED;
  return 0;
}

int VirtualV4l2Queue::qbuf(int file, v4l2_buffer* buffer, int dmabuf_fd, uint32_t sizeimage) {
  if (buffer->type != V4L2_BUF_TYPE_VIDEO_CAPTURE || buffer->memory != memory_) return -EINVAL;
  if (int error = check_owner(file)) return error;
  if (buffer->index >= buffers_.size()) return -EINVAL;
  Buffer& b = buffers_[buffer->index];
  if (b.state != Buffer::State::kDequeued) return -EINVAL;
  if (memory_ == V4L2_MEMORY_DMABUF) {
    const int fd = dmabuf_fd >= 0 ? dmabuf_fd : buffer->m.fd;
    if (int error = import_dmabuf(b, fd, buffer->length, sizeimage); error < 0) return error;
    b.user_fd = buffer->m.fd;
  }
  if (memory_ == V4L2_MEMORY_USERPTR) {
    // vb2's __prepare_userptr: no pointer, or room for less than a frame, is EINVAL
    // (whether the memory is there is the caller's check: it is the client's memory).
    if (buffer->m.userptr == 0 || buffer->length < sizeimage) return -EINVAL;
    b.user_pointer = buffer->m.userptr;
    b.user_length = buffer->length;
  }
  b.state = Buffer::State::kQueued;
  queued_order_.push_back(static_cast<int>(buffer->index));
  buffer->flags &= ~(V4L2_BUF_FLAG_NO_CACHE_INVALIDATE | V4L2_BUF_FLAG_NO_CACHE_CLEAN);
  return querybuf(buffer, sizeimage);
}

int VirtualV4l2Queue::import_dmabuf(Buffer& b, int fd, uint32_t asked_length, uint32_t sizeimage) {
  // As vb2's __prepare_dmabuf: a length of 0 means the whole buffer; less than the
  // format's sizeimage is EINVAL, more than the buffer has is EFAULT (attach_dmabuf).
  struct stat st {};
  if (fd < 0 || fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) return -EINVAL;  // not a buffer fd
  const auto size = static_cast<size_t>(st.st_size);
  const size_t length = asked_length ? asked_length : size;
  if (length < sizeimage) return -EINVAL;
  if (size < length) return -EFAULT;
  // The same buffer queued again keeps its mapping (as vb2 keeps the attachment).
  if (b.mapping && b.import_device == st.st_dev && b.import_inode == st.st_ino &&
      b.mapping.size() >= length) {
    b.dmabuf_length = static_cast<uint32_t>(length);
    return 0;
  }
  MappedBuffer mapping(mmap(nullptr, length, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0), length);
  if (!mapping) return -EINVAL;
  b.mapping = std::move(mapping);  // unmaps the previous import
  b.import_device = st.st_dev;
  b.import_inode = st.st_ino;
  b.dmabuf_length = static_cast<uint32_t>(length);
  return 0;
}

int VirtualV4l2Queue::check_dqbuf(int file, const v4l2_buffer& buffer) const {
  if (buffer.type != V4L2_BUF_TYPE_VIDEO_CAPTURE || buffer.memory != memory_) return -EINVAL;
  return check_owner(file);
}

void VirtualV4l2Queue::dqbuf(v4l2_buffer* buffer) {
  const int index = done_order_.front();
  done_order_.pop_front();
  Buffer& b = buffers_[static_cast<size_t>(index)];
  *buffer = b.done;
  b.state = Buffer::State::kDequeued;
  buffer->memory = memory_;
  if (memory_ == V4L2_MEMORY_DMABUF) {
    buffer->m.fd = b.user_fd;
    buffer->length = b.dmabuf_length;
  } else if (memory_ == V4L2_MEMORY_USERPTR) {
    buffer->m.userptr = b.user_pointer;
    buffer->length = b.user_length;
  } else {
    buffer->m.offset = static_cast<uint32_t>(static_cast<size_t>(index) * stride_bytes_);
  }
  buffer->flags &= ~(V4L2_BUF_FLAG_QUEUED | V4L2_BUF_FLAG_DONE);
  if (b.mappings > 0) buffer->flags |= V4L2_BUF_FLAG_MAPPED;
}

int VirtualV4l2Queue::expbuf(v4l2_exportbuffer* exported) const {
  // vb2_core_expbuf's checks, in its order.
  if (exported->flags & ~(O_CLOEXEC | O_ACCMODE)) return -EINVAL;
  if (exported->type != V4L2_BUF_TYPE_VIDEO_CAPTURE || memory_ != V4L2_MEMORY_MMAP) return -EINVAL;
  if (exported->index >= buffers_.size() || exported->plane != 0) return -EINVAL;
  const int memfd = buffers_[exported->index].memfd.get();
  // A new open file description of the memfd, so the access mode asked for holds; a dup
  // (same description) only if /proc is not mounted.
  const std::string self = "/proc/self/fd/" + std::to_string(memfd);
  UniqueFd fd(open(self.c_str(), static_cast<int>(exported->flags & (O_CLOEXEC | O_ACCMODE))));
  if (!fd) fd.reset(fcntl(memfd, (exported->flags & O_CLOEXEC) ? F_DUPFD_CLOEXEC : F_DUPFD, 0));
  if (!fd) return -errno;
  std::memset(exported->reserved, 0, sizeof exported->reserved);
  exported->fd = fd.release();  // the caller's now
  return 0;
}

int VirtualV4l2Queue::userptr_source(uint32_t index, BufferMemory* out) const {
  if (memory_ != V4L2_MEMORY_USERPTR || index >= buffers_.size()) return -EINVAL;
  const Buffer& b = buffers_[index];
  *out = {b.memfd.get(), b.mapping.data(), b.mapping.size()};
  return 0;
}

int VirtualV4l2Queue::streamon() {
  if (buffers_.empty()) return -EINVAL;
  streaming_ = true;
  return 0;
}

void VirtualV4l2Queue::streamoff() {
  streaming_ = false;
  for (auto& b : buffers_) b.state = Buffer::State::kDequeued;
  queued_order_.clear();
  done_order_.clear();
}

void VirtualV4l2Queue::release(int file) {
  if (owner_ != file) return;
  streamoff();
  bool mapped = false;
  for (const auto& b : buffers_) mapped |= b.mappings > 0;
  if (!mapped) free_buffers();
  owner_ = 0;
}

int VirtualV4l2Queue::buffer_for_mmap(off_t offset, size_t length, BufferMemory* out) const {
  // Imported buffers are mapped through their own fd.
  if (memory_ != V4L2_MEMORY_MMAP) return -EINVAL;
  if (stride_bytes_ == 0 || offset < 0 || static_cast<size_t>(offset) % stride_bytes_ != 0)
    return -EINVAL;
  const size_t index = static_cast<size_t>(offset) / stride_bytes_;
  if (index >= buffers_.size() || length == 0 || length > buffers_[index].mapping.size())
    return -EINVAL;
  const Buffer& b = buffers_[index];
  *out = {b.memfd.get(), b.mapping.data(), b.mapping.size()};
  return 0;
}

void VirtualV4l2Queue::note_mapping(off_t offset, int delta) {
  if (stride_bytes_ == 0) return;
  const size_t index = static_cast<size_t>(offset) / stride_bytes_;
  if (index < buffers_.size())
    buffers_[index].mappings = std::max(0, buffers_[index].mappings + delta);
}

int VirtualV4l2Queue::start_filling() {
  const int index = queued_order_.front();
  queued_order_.pop_front();
  buffers_[static_cast<size_t>(index)].state = Buffer::State::kFilling;
  return index;
}

uint8_t* VirtualV4l2Queue::filling_memory(int index, uint64_t generation) const {
  if (generation != generation_ || !streaming_) return nullptr;
  const Buffer& buffer = buffers_[static_cast<size_t>(index)];
  return buffer.state == Buffer::State::kFilling ? buffer.mapping.data() : nullptr;
}

void VirtualV4l2Queue::complete(int index, v4l2_buffer done, uint32_t sizeimage) {
  Buffer& buffer = buffers_[static_cast<size_t>(index)];
  done.memory = memory_;
  done.length = memory_ == V4L2_MEMORY_DMABUF    ? buffer.dmabuf_length
                : memory_ == V4L2_MEMORY_USERPTR ? buffer.user_length
                                                 : sizeimage;
  buffer.done = done;
  buffer.state = Buffer::State::kDone;
  done_order_.push_back(index);
}

}  // namespace camlab::mock
