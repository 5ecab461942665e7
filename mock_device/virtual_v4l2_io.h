// The in-process transport of the virtual V4L2 device: a V4l2Io (src/device/v4l2_io.h)
// on which /dev/videoN is the virtual camera N. The V4L2 backend runs its real ioctl
// code against it; only the system-call layer is replaced. Device fds are real eventfds
// (unique numbers, closable), buffers are the device's memfds mapped for real.
// Any other path or fd goes to the real system calls.
//
// Thread-safe.
#pragma once

#include <map>
#include <memory>
#include <mutex>
#include <vector>

#include "device/v4l2_io.h"
#include "mock_device/virtual_v4l2_device.h"

namespace camlab::mock {

class VirtualV4l2Io final : public device::V4l2Io {
 public:
  // devices[i] appears as /dev/video<devices[i]->index()>.
  explicit VirtualV4l2Io(std::vector<std::shared_ptr<VirtualV4l2Device>> devices);
  ~VirtualV4l2Io() override;

  int open(const char* path, int flags) override;
  int close(int fd) override;
  int ioctl(int fd, unsigned long request, void* arg) override;
  void* mmap(size_t length, int prot, int flags, int fd, off_t offset) override;
  int munmap(void* address, size_t length) override;
  int poll(struct pollfd* fds, nfds_t count, int timeout_ms) override;

  // Whether an fd is an open virtual device, or an address one of its buffer mappings
  // (a transport routes only those here).
  bool owns(int fd) const;
  bool owns_mapping(void* address) const;
  // The /dev/videoN number of an open device fd, -1 if it is none.
  int device_index_of(int fd) const;

  // Open device fds and live buffer mappings (for leak checks in tests).
  size_t open_fd_count() const;
  size_t mapping_count() const;

 private:
  struct OpenFile {
    std::shared_ptr<VirtualV4l2Device> device;
    int file;
  };
  struct Mapping {
    std::shared_ptr<VirtualV4l2Device> device;
    off_t offset;
    size_t length;
  };
  bool find(int fd, OpenFile* out) const;

  std::vector<std::shared_ptr<VirtualV4l2Device>> devices_;
  mutable std::mutex mutex_;
  std::map<int, OpenFile> files_;
  std::map<void*, Mapping> mappings_;
};

}  // namespace camlab::mock
