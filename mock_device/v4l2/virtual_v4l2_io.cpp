#include "mock_device/v4l2/virtual_v4l2_io.h"

#include <fcntl.h>
#include <sys/eventfd.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <sys/uio.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

namespace camlab::mock {

namespace {

// Copies between this process's memory and a possibly bad address, as copy_from_user
// and copy_to_user do: -EFAULT instead of a crash.
int copy_from_self(uint64_t address, void* local, size_t bytes) {
  iovec here{local, bytes};
  iovec there{reinterpret_cast<void*>(static_cast<uintptr_t>(address)), bytes};
  return bytes == 0 ||
                 process_vm_readv(getpid(), &here, 1, &there, 1, 0) == static_cast<ssize_t>(bytes)
             ? 0
             : -EFAULT;
}

int copy_to_self(uint64_t address, const void* local, size_t bytes) {
  iovec here{const_cast<void*>(local), bytes};
  iovec there{reinterpret_cast<void*>(static_cast<uintptr_t>(address)), bytes};
  return bytes == 0 ||
                 process_vm_writev(getpid(), &here, 1, &there, 1, 0) == static_cast<ssize_t>(bytes)
             ? 0
             : -EFAULT;
}

}  // namespace

VirtualV4l2Io::VirtualV4l2Io(std::vector<std::shared_ptr<VirtualV4l2Device>> devices)
    : devices_(std::move(devices)) {
  for (const auto& device : devices_) {
    auto media = make_media_device_for(*device);
    if (!media) continue;
    UniqueFd memfd(memfd_create("camlab-vcam-media", MFD_CLOEXEC));
    if (!memfd) continue;
    media_.push_back({std::move(media), std::move(memfd)});
  }
}

VirtualV4l2Io::~VirtualV4l2Io() {
  mappings_.clear();  // unmapped by their owners
  for (auto& [fd, owned] : files_) {
    if (owned.file.device) owned.file.device->close_file(owned.file.file);
    if (owned.file.media) owned.file.media->close_file(owned.file.file);
    owned.fd.reset();
  }
  // The media nodes' memfds close with media_.
}

std::shared_ptr<VirtualMediaDevice> VirtualV4l2Io::media_device(int index) const {
  for (const auto& node : media_)
    if (node.device->index() == index) return node.device;
  return nullptr;
}

int VirtualV4l2Io::open_media(const MediaNode& node, int flags) {
  const int file = node.device->open_file((flags & O_NONBLOCK) != 0);
  if (file < 0) {
    errno = -file;
    return -1;
  }
  // A new open file description of the node's memfd: one inode per media node, so
  // POSIX locks taken through any of its fds see each other, as on /dev/mediaN.
  const std::string self = "/proc/self/fd/" + std::to_string(node.lock_memfd.get());
  UniqueFd fd(::open(self.c_str(), O_RDWR | O_CLOEXEC | (flags & O_NONBLOCK)));
  if (!fd) fd.reset(::fcntl(node.lock_memfd.get(), F_DUPFD_CLOEXEC, 0));
  if (!fd) {
    node.device->close_file(file);
    return -1;
  }
  const int number = fd.get();
  std::lock_guard lock(mutex_);
  files_[number] = {std::move(fd), {nullptr, node.device, file}};
  return number;
}

int VirtualV4l2Io::media_ioctl(const OpenFile& file, unsigned long request, void* arg) {
  // The kernel's order: unknown ioctls are ENOTTY before the argument is looked at.
  if (!VirtualMediaDevice::is_supported_ioctl(request)) return -ENOTTY;
  const auto address = static_cast<uint64_t>(reinterpret_cast<uintptr_t>(arg));
  std::vector<uint8_t> local(_IOC_SIZE(request));
  if (int error = copy_from_self(address, local.data(), local.size()); error < 0 || arg == nullptr)
    return -EFAULT;
  const int result =
      file.media->ioctl_marshalled(file.file, request, local.data(), copy_from_self, copy_to_self);
  if (result < 0) return result;  // the struct reaches the caller only on success
  return copy_to_self(address, local.data(), local.size());
}

bool VirtualV4l2Io::find(int fd, OpenFile* out) const {
  std::lock_guard lock(mutex_);
  auto it = files_.find(fd);
  if (it == files_.end()) return false;
  *out = it->second.file;
  return true;
}

int VirtualV4l2Io::open(const char* path, int flags) {
  const std::string p = path ? path : "";
  for (const auto& node : media_)
    if (p == "/dev/media" + std::to_string(node.device->index())) return open_media(node, flags);
  for (const auto& device : devices_) {
    if (p != "/dev/video" + std::to_string(device->index())) continue;
    const int file = device->open_file((flags & O_NONBLOCK) != 0);
    if (file < 0) {
      errno = -file;
      return -1;
    }
    UniqueFd fd(::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK));
    if (!fd) {
      device->close_file(file);
      return -1;
    }
    device->attach_eventfd(file, fd.get());  // lent: the device writes readiness to it
    const int number = fd.get();
    std::lock_guard lock(mutex_);
    files_[number] = {std::move(fd), {device, nullptr, file}};
    return number;
  }
  return ::open(path, flags | O_CLOEXEC);
}

int VirtualV4l2Io::close(int fd) {
  OwnedFile owned;
  {
    std::lock_guard lock(mutex_);
    auto it = files_.find(fd);
    if (it == files_.end()) return ::close(fd);  // not ours: the system call
    owned = std::move(it->second);
    files_.erase(it);
  }
  if (owned.file.device) owned.file.device->close_file(owned.file.file);
  if (owned.file.media) owned.file.media->close_file(owned.file.file);
  owned.fd.reset();
  return 0;
}

int VirtualV4l2Io::ioctl(int fd, unsigned long request, void* arg) {
  OpenFile file;
  if (!find(fd, &file)) return ::ioctl(fd, request, arg);
  const auto* buffer = static_cast<const v4l2_buffer*>(arg);
  const bool userptr = !file.media && arg != nullptr &&
                       (request == VIDIOC_QBUF || request == VIDIOC_DQBUF) &&
                       buffer->memory == V4L2_MEMORY_USERPTR;
  // A USERPTR buffer must be memory the application has (vb2 pins it at QBUF).
  uint8_t probe = 0;
  if (userptr && request == VIDIOC_QBUF && buffer->m.userptr != 0 && buffer->length > 0 &&
      (copy_from_self(buffer->m.userptr, &probe, 1) != 0 ||
       copy_from_self(buffer->m.userptr + buffer->length - 1, &probe, 1) != 0)) {
    errno = EFAULT;
    return -1;
  }
  int result =
      file.media ? media_ioctl(file, request, arg) : file.device->ioctl(file.file, request, arg);
  if (result == 0 && userptr && request == VIDIOC_DQBUF) {
    // The frame to the application's pointer, as uvcvideo copies it into the buffer.
    VirtualV4l2Device::BufferMemory source{};
    result = file.device->userptr_source(buffer->index, &source);
    if (result == 0)
      result = copy_to_self(buffer->m.userptr, source.address,
                            std::min<size_t>(buffer->bytesused, source.length));
  }
  if (result < 0) {
    errno = -result;
    return -1;
  }
  return result;
}

void* VirtualV4l2Io::mmap(size_t length, int prot, int flags, int fd, off_t offset) {
  OpenFile file;
  if (!find(fd, &file)) return ::mmap(nullptr, length, prot, flags, fd, offset);
  if (file.media) {
    errno = ENODEV;  // a media node has no mmap
    return MAP_FAILED;
  }
  if (!(flags & MAP_SHARED)) {
    errno = EINVAL;  // V4L2 buffers must be mapped shared
    return MAP_FAILED;
  }
  VirtualV4l2Device::BufferMemory memory{};
  if (int error = file.device->buffer_for_mmap(offset, length, &memory); error < 0) {
    errno = -error;
    return MAP_FAILED;
  }
  MappedBuffer mapped(::mmap(nullptr, length, prot, flags, memory.memfd, 0), length);
  if (!mapped) return MAP_FAILED;
  file.device->note_mapping(offset, +1);
  void* address = mapped.data();
  std::lock_guard lock(mutex_);
  mappings_[address] = {file.device, offset, std::move(mapped)};
  return address;
}

int VirtualV4l2Io::munmap(void* address, size_t length) {
  Mapping mapping;
  {
    std::lock_guard lock(mutex_);
    auto it = mappings_.find(address);
    if (it == mappings_.end()) return ::munmap(address, length);  // not ours: the system call
    mapping = std::move(it->second);
    mappings_.erase(it);
  }
  mapping.device->note_mapping(mapping.offset, -1);
  mapping.memory.reset();  // the whole mapping, as made
  return 0;
}

int VirtualV4l2Io::poll(struct pollfd* fds, nfds_t count, int timeout_ms) {
  // One device fd alone (the backend's case) waits on the device; a mix of fds is
  // polled in short steps until something is ready or the timeout passes.
  if (count == 1) {
    OpenFile file;
    if (find(fds[0].fd, &file) && file.device) {
      fds[0].revents = file.device->wait_events(file.file, fds[0].events, timeout_ms);
      return fds[0].revents ? 1 : 0;
    }
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
  for (;;) {
    int ready = 0;
    for (nfds_t i = 0; i < count; ++i) {
      OpenFile file;
      if (find(fds[i].fd, &file) && file.media) {
        // A media node has no poll: the kernel reports DEFAULT_POLLMASK.
        fds[i].revents = fds[i].events & (POLLIN | POLLOUT | POLLRDNORM | POLLWRNORM);
      } else if (file.device) {
        fds[i].revents = file.device->wait_events(file.file, fds[i].events, 0);
      } else {
        pollfd single = fds[i];
        if (::poll(&single, 1, 0) < 0) return -1;
        fds[i].revents = single.revents;
      }
      ready += fds[i].revents != 0;
    }
    if (ready > 0 || timeout_ms == 0 ||
        (timeout_ms > 0 && std::chrono::steady_clock::now() >= deadline))
      return ready;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
}

bool VirtualV4l2Io::owns(int fd) const {
  std::lock_guard lock(mutex_);
  return files_.count(fd) != 0;
}

bool VirtualV4l2Io::owns_mapping(void* address) const {
  std::lock_guard lock(mutex_);
  return mappings_.count(address) != 0;
}

int VirtualV4l2Io::device_index_of(int fd) const {
  std::lock_guard lock(mutex_);
  auto it = files_.find(fd);
  return it == files_.end() || !it->second.file.device ? -1 : it->second.file.device->index();
}

size_t VirtualV4l2Io::open_fd_count() const {
  std::lock_guard lock(mutex_);
  return files_.size();
}

size_t VirtualV4l2Io::mapping_count() const {
  std::lock_guard lock(mutex_);
  return mappings_.size();
}

}  // namespace camlab::mock
