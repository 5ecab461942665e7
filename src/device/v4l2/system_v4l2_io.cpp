#include <fcntl.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cerrno>

#include "device/v4l2/v4l2_io.h"

namespace camlab::device {

namespace {

class SystemV4l2Io final : public V4l2Io {
 public:
  int open(const char* path, int flags) override { return ::open(path, flags | O_CLOEXEC); }
  int close(int fd) override { return ::close(fd); }
  int ioctl(int fd, unsigned long request, void* arg) override { return ::ioctl(fd, request, arg); }
  void* mmap(size_t length, int prot, int flags, int fd, off_t offset) override {
    return ::mmap(nullptr, length, prot, flags, fd, offset);
  }
  int munmap(void* address, size_t length) override { return ::munmap(address, length); }
  int poll(struct pollfd* fds, nfds_t count, int timeout_ms) override {
    return ::poll(fds, count, timeout_ms);
  }
};

}  // namespace

std::shared_ptr<V4l2Io> system_v4l2_io() {
  static auto io = std::make_shared<SystemV4l2Io>();
  return io;
}

int xioctl(V4l2Io& io, int fd, unsigned long request, void* arg) {
  int result;
  do {
    result = io.ioctl(fd, request, arg);
  } while (result == -1 && errno == EINTR);
  return result;
}

}  // namespace camlab::device
