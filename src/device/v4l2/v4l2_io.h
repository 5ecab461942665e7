// The seam under the V4L2 backend: the handful of system calls a V4L2 client makes.
// SystemV4l2Io passes them to the kernel (or to whatever LD_PRELOAD put in front of it);
// the virtual camera implements the same interface in process, so the backend's real
// ioctl code runs unchanged against it in fast, deterministic tests.
//
// Calls follow the system-call conventions: -1 (or MAP_FAILED) and errno on failure.
// Implementations are thread-safe.
#pragma once

#include <poll.h>
#include <sys/types.h>

#include <memory>

#include "base/mapped_buffer.h"
#include "base/unique_fd.h"

namespace camlab::device {

class V4l2Io {
 public:
  virtual ~V4l2Io() = default;
  virtual int open(const char* path, int flags) = 0;
  virtual int close(int fd) = 0;
  virtual int ioctl(int fd, unsigned long request, void* arg) = 0;
  virtual void* mmap(size_t length, int prot, int flags, int fd, off_t offset) = 0;
  virtual int munmap(void* address, size_t length) = 0;
  virtual int poll(struct pollfd* fds, nfds_t count, int timeout_ms) = 0;
};

// The real system calls.
std::shared_ptr<V4l2Io> system_v4l2_io();

// ioctl retried on EINTR, as every V4L2 client must.
int xioctl(V4l2Io& io, int fd, unsigned long request, void* arg);

// Owners of what a V4l2Io opened or mapped: closed or unmapped through the same seam
// (base/unique_fd.h, base/mapped_buffer.h). The V4l2Io must outlive them.
struct V4l2IoFdCloser {
  V4l2Io* io = nullptr;
  void operator()(int fd) const noexcept { io->close(fd); }
};
struct V4l2IoUnmapper {
  V4l2Io* io = nullptr;
  void operator()(void* address, size_t length) const noexcept { io->munmap(address, length); }
};
using V4l2Fd = BasicUniqueFd<V4l2IoFdCloser>;
using V4l2Mapping = BasicMappedBuffer<V4l2IoUnmapper>;

}  // namespace camlab::device
