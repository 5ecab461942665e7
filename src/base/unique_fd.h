// Owners of file descriptors: a descriptor is closed exactly once, when its owner goes or
// is reset. Every descriptor camlab opens has one (docs/architecture.md, "Ownership").
//
//   UniqueFd memfd(::memfd_create("frame", MFD_CLOEXEC));
//   if (!memfd) return errno;
//   ::ftruncate(memfd.get(), size);             // borrow the number for a call
//   send_fd(socket, memfd.get());               // the peer gets its own copy
//   // memfd closes here
//
// The descriptor goes back through a Closer: the system call by default, or the seam it
// came from (device::V4l2Io for the V4L2 backend; the real libc inside the preload
// library, where ::close is the interposed one).
//
// Thread-compatible: one owner; its number may be lent for a call, never its ownership.
// Header-only, so that the preload library can use it without linking camlab_base.
#pragma once

#include <unistd.h>

#include <cerrno>
#include <utility>

namespace camlab {

struct SystemFdCloser {
  void operator()(int fd) const noexcept { ::close(fd); }
};

template <class Closer = SystemFdCloser>
class BasicUniqueFd {
 public:
  BasicUniqueFd() = default;
  // Takes ownership of `fd` (a negative fd: owns nothing).
  explicit BasicUniqueFd(int fd, Closer closer = Closer()) noexcept
      : fd_(fd), closer_(std::move(closer)) {}
  BasicUniqueFd(BasicUniqueFd&& other) noexcept
      : fd_(other.release()), closer_(std::move(other.closer_)) {}
  BasicUniqueFd& operator=(BasicUniqueFd&& other) noexcept {
    if (this != &other) {
      reset(other.release());
      closer_ = std::move(other.closer_);
    }
    return *this;
  }
  BasicUniqueFd(const BasicUniqueFd&) = delete;
  BasicUniqueFd& operator=(const BasicUniqueFd&) = delete;
  ~BasicUniqueFd() { reset(); }

  int get() const noexcept { return fd_; }
  bool is_valid() const noexcept { return fd_ >= 0; }
  explicit operator bool() const noexcept { return is_valid(); }

  // Gives the descriptor up without closing it (to a transfer that closes it itself).
  [[nodiscard]] int release() noexcept { return std::exchange(fd_, -1); }
  // Closes the descriptor held, if any, and holds `fd` instead. errno is kept, so that an
  // owner going out of scope after a failed call leaves the caller the call's errno.
  void reset(int fd = -1) noexcept {
    if (fd_ >= 0 && fd_ != fd) {
      const int saved_errno = errno;
      closer_(fd_);
      errno = saved_errno;
    }
    fd_ = fd;
  }

 private:
  int fd_ = -1;
  [[no_unique_address]] Closer closer_;
};

using UniqueFd = BasicUniqueFd<>;

}  // namespace camlab
