// The in-process transport of the virtual V4L2 device: a V4l2Io (src/device/v4l2/v4l2_io.h)
// on which /dev/videoN is the virtual camera N and /dev/mediaN its media controller
// node (mock_device/v4l2/virtual_media_device.h). The V4L2 backend runs its real ioctl code
// against it; only the system-call layer is replaced. Video fds are real eventfds
// (unique numbers, closable, readable while a frame is ready); media fds are fresh opens
// of one memfd per media node, so lockf() on them works as on the real node (libcamera
// locks the media device). Buffers are the device's memfds mapped for real; exported
// buffers (VIDIOC_EXPBUF) are ordinary fds of this process. Media ioctls are copied in
// and out with process_vm_readv/writev, arrays included, so a bad pointer is EFAULT as
// from the kernel. Any other path or fd goes to the real system calls.
//
// Every fd and mapping it makes has an owner (UniqueFd, MappedBuffer); close and munmap
// forward to the system calls only what it does not own.
//
// Thread-safe.
#pragma once

#include <map>
#include <memory>
#include <mutex>
#include <vector>

#include "base/mapped_buffer.h"
#include "base/unique_fd.h"
#include "device/v4l2/v4l2_io.h"
#include "mock_device/v4l2/virtual_media_device.h"
#include "mock_device/v4l2/virtual_v4l2_device.h"

namespace camlab::mock {

class VirtualV4l2Io final : public device::V4l2Io {
 public:
  // devices[i] appears as /dev/video<devices[i]->index()>, and its media node
  // (make_media_device_for) as /dev/media<devices[i]->index()>.
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
  // The /dev/videoN number of an open video fd, -1 if it is none.
  int device_index_of(int fd) const;
  // The media node of camera `index`, null if there is none.
  std::shared_ptr<VirtualMediaDevice> media_device(int index) const;

  // Open device fds and live buffer mappings (for leak checks in tests).
  size_t open_fd_count() const;
  size_t mapping_count() const;

 private:
  struct OpenFile {
    std::shared_ptr<VirtualV4l2Device> device;  // set for a video fd
    std::shared_ptr<VirtualMediaDevice> media;  // set for a media fd
    int file;
  };
  // An fd this transport made (a video fd's eventfd, a media fd's open of the node's
  // memfd) and the device's open file it stands for.
  struct OwnedFile {
    UniqueFd fd;
    OpenFile file;
  };
  struct MediaNode {
    std::shared_ptr<VirtualMediaDevice> device;
    UniqueFd lock_memfd;  // the inode every open of this node refers to
  };
  // A client's mapping of a device buffer, made here and unmapped by its owner.
  struct Mapping {
    std::shared_ptr<VirtualV4l2Device> device;
    off_t offset;
    MappedBuffer memory;
  };
  int open_media(const MediaNode& node, int flags);
  int media_ioctl(const OpenFile& file, unsigned long request, void* arg);
  bool find(int fd, OpenFile* out) const;

  std::vector<std::shared_ptr<VirtualV4l2Device>> devices_;
  std::vector<MediaNode> media_;
  mutable std::mutex mutex_;
  std::map<int, OwnedFile> files_;     // by fd number
  std::map<void*, Mapping> mappings_;  // by address
};

}  // namespace camlab::mock
