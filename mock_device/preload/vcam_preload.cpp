// libcamlab_vcam_preload.so: the virtual camera as /dev/video0.. for an unmodified V4L2
// client, in user space (the machines camlab is tested on have no kernel media support).
//
// Loaded with LD_PRELOAD by `camlab vcam run`, it interposes the libc entry points a
// V4L2 client uses on a device: open/openat (and their 64 and fortified forms), close,
// ioctl, mmap/munmap, poll/ppoll/select, and the stat family (a character device, major
// 81). Device paths and fds go to VirtualV4l2Device through VirtualV4l2Io; everything
// else goes straight to the next definition (dlsym RTLD_NEXT), so the library's own
// calls never loop back into it. ioctl arguments are copied in and out through
// process_vm_readv/writev, so a bad pointer is EFAULT, as from the kernel, not a crash.
//
// This version keeps the device in the client process: each process sees its own
// camera. Sharing one device across processes goes through the broker (next step).
//
// Configuration (environment, set by `camlab vcam run`): CAMLAB_VCAM_CAMERA (camera spec
// path), CAMLAB_VCAM_SCENE (scene spec path, optional), CAMLAB_VCAM_COUNT (devices, 1).
#include <dirent.h>
#include <dlfcn.h>
#include <fcntl.h>
#include <linux/videodev2.h>
#include <poll.h>
#include <stdarg.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <sys/select.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <sys/uio.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "mock_device/fake_sysfs.h"
#include "mock_device/virtual_v4l2_io.h"

namespace {

using camlab::mock::VirtualV4l2Device;
using camlab::mock::VirtualV4l2Io;

template <class F>
F next(const char* name) {
  return reinterpret_cast<F>(dlsym(RTLD_NEXT, name));
}

struct Real {
  int (*open)(const char*, int, ...) = next<int (*)(const char*, int, ...)>("open");
  int (*openat)(int, const char*, int, ...) = next<int (*)(int, const char*, int, ...)>("openat");
  int (*close)(int) = next<int (*)(int)>("close");
  int (*ioctl)(int, unsigned long, ...) = next<int (*)(int, unsigned long, ...)>("ioctl");
  void* (*mmap)(void*, size_t, int, int, int, off_t) = next<void* (*)(void*, size_t, int, int, int, off_t)>("mmap");
  int (*munmap)(void*, size_t) = next<int (*)(void*, size_t)>("munmap");
  int (*poll)(pollfd*, nfds_t, int) = next<int (*)(pollfd*, nfds_t, int)>("poll");
  int (*select)(int, fd_set*, fd_set*, fd_set*, timeval*) =
      next<int (*)(int, fd_set*, fd_set*, fd_set*, timeval*)>("select");
  int (*fstat)(int, struct stat*) = next<int (*)(int, struct stat*)>("fstat");
  int (*stat)(const char*, struct stat*) = next<int (*)(const char*, struct stat*)>("stat");
  int (*lstat)(const char*, struct stat*) = next<int (*)(const char*, struct stat*)>("lstat");
  int (*fstatat)(int, const char*, struct stat*, int) = next<int (*)(int, const char*, struct stat*, int)>("fstatat");
  int (*access)(const char*, int) = next<int (*)(const char*, int)>("access");
};

Real& real() {
  static Real r;
  return r;
}

int device_index(const char* path) {
  if (!path || std::strncmp(path, "/dev/video", 10) != 0) return -1;
  const char* digits = path + 10;
  if (!*digits) return -1;
  for (const char* p = digits; *p; ++p)
    if (*p < '0' || *p > '9') return -1;
  const int index = std::atoi(digits);
  const char* count_text = std::getenv("CAMLAB_VCAM_COUNT");
  const int count = count_text ? std::atoi(count_text) : 1;
  return index < count ? index : -1;
}

// The devices of this process, created on first use (a renderer costs a lens
// unprojection, so a process that never opens a camera pays nothing).
class Devices {
 public:
  static Devices& get() {
    static Devices devices;
    return devices;
  }
  VirtualV4l2Io* io() {
    std::call_once(once_, [this] { create(); });
    return io_.get();
  }
  bool owns(int fd) { return io_ && io_->owns(fd); }
  bool owns_mapping(void* address) { return io_ && io_->owns_mapping(address); }

 private:
  void create() {
    const char* camera_path = std::getenv("CAMLAB_VCAM_CAMERA");
    const char* scene_path = std::getenv("CAMLAB_VCAM_SCENE");
    const char* count_text = std::getenv("CAMLAB_VCAM_COUNT");
    const int count = count_text ? std::max(1, std::atoi(count_text)) : 1;
    std::vector<std::shared_ptr<VirtualV4l2Device>> devices;
    if (!camera_path) {
      std::fprintf(stderr, "camlab vcam: CAMLAB_VCAM_CAMERA is not set; no virtual camera\n");
    } else {
      for (int i = 0; i < count; ++i) {
        auto camera = camlab::mock::load_camera_spec(camera_path);
        nlohmann::json default_scene = {
            {"targets", {{{"type", "chessboard"}, {"inner_corners", {9, 6}}, {"square_m", 0.03},
                          {"pose", {{"position_m", {-0.12, -0.075, 0.6}}}}}}}};
        auto scene = scene_path ? camlab::mock::load_scene_spec(scene_path)
                                : camlab::mock::parse_scene_spec(default_scene);
        if (!camera || !scene) {
          std::fprintf(stderr, "camlab vcam: %s\n", (!camera ? camera.error() : scene.error()).message.c_str());
          break;
        }
        camlab::mock::VirtualDeviceOptions options;
        options.index = i;
        options.seed = static_cast<uint64_t>(i) + 1;
        auto device = VirtualV4l2Device::create(std::move(*camera), std::move(*scene), options);
        if (!device) {
          std::fprintf(stderr, "camlab vcam: %s\n", device.error().message.c_str());
          break;
        }
        devices.push_back(std::move(*device));
      }
    }
    io_ = std::make_unique<VirtualV4l2Io>(std::move(devices));
  }

  std::once_flag once_;
  std::unique_ptr<VirtualV4l2Io> io_;
};

int vcam_count() {
  const char* count_text = std::getenv("CAMLAB_VCAM_COUNT");
  return count_text ? std::max(1, std::atoi(count_text)) : 1;
}

// A fake sysfs for the virtual devices: clients such as v4l2-ctl read
// /sys/dev/char/81:N/uevent to learn that a character device is a video node, and
// enumerators walk /sys/class/video4linux. The tree is real files in a temporary folder
// (CAMLAB_VCAM_SYSFS, made by `camlab vcam run`, else made here on first need); paths
// under those two sysfs roots are redirected into it.
class FakeSysfs {
 public:
  static FakeSysfs& get() {
    static FakeSysfs sysfs;
    return sysfs;
  }
  // The redirected path, or nullptr when `path` is not one of ours.
  const char* rewrite(const char* path, std::string* storage) {
    if (!path || std::strncmp(path, "/sys/", 5) != 0) return nullptr;
    bool ours = std::strncmp(path, "/sys/class/video4linux", 22) == 0;
    if (!ours && std::strncmp(path, "/sys/dev/char/81:", 17) == 0) {
      const int minor = std::atoi(path + 17);
      ours = minor < vcam_count();
    }
    if (!ours) return nullptr;
    *storage = root() + (path + 4);  // keep everything after "/sys"
    return storage->c_str();
  }

 private:
  const std::string& root() {
    std::call_once(once_, [this] { build(); });
    return root_;
  }
  void build() {
    if (const char* given = std::getenv("CAMLAB_VCAM_SYSFS")) {
      root_ = given;
      return;
    }
    char dir[] = "/tmp/camlab-vcam-sysfs-XXXXXX";
    if (!mkdtemp(dir)) return;
    root_ = dir;
    created_here_ = true;
    camlab::mock::write_sysfs_tree(root_, vcam_count());
  }
  ~FakeSysfs() {
    if (!created_here_) return;
    std::error_code ec;
    std::filesystem::remove_all(root_, ec);
  }
  std::once_flag once_;
  std::string root_;
  bool created_here_ = false;
};

int open_device(const char* path, int flags) {
  VirtualV4l2Io* io = Devices::get().io();
  return io->open(path, flags);
}

// Copies `size` bytes between this process's memory and a buffer with the kernel's
// EFAULT semantics: a bad pointer fails the call instead of crashing the caller.
bool copy_from_user(void* to, const void* from, size_t size) {
  iovec local{to, size}, remote{const_cast<void*>(from), size};
  return process_vm_readv(getpid(), &local, 1, &remote, 1, 0) == static_cast<ssize_t>(size);
}
bool copy_to_user(void* to, const void* from, size_t size) {
  iovec local{const_cast<void*>(from), size}, remote{to, size};
  return process_vm_writev(getpid(), &local, 1, &remote, 1, 0) == static_cast<ssize_t>(size);
}

int device_ioctl(int fd, unsigned long request, void* arg) {
  VirtualV4l2Io* io = Devices::get().io();
  if (!VirtualV4l2Device::is_supported_ioctl(request)) return io->ioctl(fd, request, nullptr);  // ENOTTY
  const size_t size = _IOC_SIZE(request);
  std::vector<unsigned char> local(std::max<size_t>(size, 1));
  if (size > 0 && (arg == nullptr || !copy_from_user(local.data(), arg, size))) {
    errno = EFAULT;
    return -1;
  }
  // Extended controls carry a pointer to an array: copy it too.
  std::vector<v4l2_ext_control> controls;
  v4l2_ext_control* user_controls = nullptr;
  const bool ext = request == VIDIOC_G_EXT_CTRLS || request == VIDIOC_S_EXT_CTRLS || request == VIDIOC_TRY_EXT_CTRLS;
  if (ext) {
    auto* header = reinterpret_cast<v4l2_ext_controls*>(local.data());
    if (header->count > 1024) {
      errno = EINVAL;
      return -1;
    }
    user_controls = header->controls;
    controls.resize(header->count);
    if (header->count > 0 &&
        (!user_controls || !copy_from_user(controls.data(), user_controls, header->count * sizeof(v4l2_ext_control)))) {
      errno = EFAULT;
      return -1;
    }
    header->controls = controls.data();
  }
  const int result = io->ioctl(fd, request, local.data());
  const int saved_errno = errno;
  if (ext) {
    auto* header = reinterpret_cast<v4l2_ext_controls*>(local.data());
    if (!controls.empty() && !copy_to_user(user_controls, controls.data(), controls.size() * sizeof(v4l2_ext_control))) {
      errno = EFAULT;
      return -1;
    }
    header->controls = user_controls;
  }
  // Like the kernel, write the struct back for _IOR and _IOWR ioctls (error_idx and
  // friends are reported on failure too).
  if ((_IOC_DIR(request) & _IOC_READ) && size > 0 && !copy_to_user(arg, local.data(), size)) {
    errno = EFAULT;
    return -1;
  }
  errno = saved_errno;
  return result;
}

void fill_device_stat(int index, struct stat* st) {
  std::memset(st, 0, sizeof *st);
  st->st_mode = S_IFCHR | 0660;
  st->st_rdev = makedev(81, static_cast<unsigned>(index));
  st->st_nlink = 1;
  st->st_blksize = 4096;
}

int fd_device_index(int fd) { return Devices::get().io()->device_index_of(fd); }

// Calls `call` with the path the client's path stands for: paths under the fake sysfs
// roots are redirected into it, every other path passes unchanged.
template <class Call>
auto on_real_path(const char* path, Call call) {
  std::string storage;
  const char* redirected = FakeSysfs::get().rewrite(path, &storage);
  return call(redirected ? redirected : path);
}

// The stat family: a virtual device node is a character device 81:N; other paths go to
// `call` (redirected when they are fake sysfs paths).
template <class Call>
int stat_path(const char* path, struct stat* st, Call call) {
  if (const int index = device_index(path); index >= 0) {
    fill_device_stat(index, st);
    return 0;
  }
  return on_real_path(path, call);
}

}  // namespace

extern "C" {

FILE* fopen(const char* path, const char* mode) {
  static auto real_fopen = next<FILE* (*)(const char*, const char*)>("fopen");
  return on_real_path(path, [&](const char* p) { return real_fopen(p, mode); });
}
FILE* fopen64(const char* path, const char* mode) { return fopen(path, mode); }

DIR* opendir(const char* path) {
  static auto real_opendir = next<DIR* (*)(const char*)>("opendir");
  return on_real_path(path, [&](const char* p) { return real_opendir(p); });
}

ssize_t readlink(const char* path, char* buffer, size_t size) {
  static auto real_readlink = next<ssize_t (*)(const char*, char*, size_t)>("readlink");
  return on_real_path(path, [&](const char* p) { return real_readlink(p, buffer, size); });
}

int open(const char* path, int flags, ...) {
  mode_t mode = 0;
  if (flags & (O_CREAT | O_TMPFILE)) {
    va_list args;
    va_start(args, flags);
    mode = va_arg(args, mode_t);
    va_end(args);
  }
  if (device_index(path) >= 0) return open_device(path, flags);
  return on_real_path(path, [&](const char* p) { return real().open(p, flags, mode); });
}
int open64(const char* path, int flags, ...) __attribute__((alias("open")));
int __open_2(const char* path, int flags) { return open(path, flags); }
int __open64_2(const char* path, int flags) { return open(path, flags); }

int openat(int dirfd, const char* path, int flags, ...) {
  mode_t mode = 0;
  if (flags & (O_CREAT | O_TMPFILE)) {
    va_list args;
    va_start(args, flags);
    mode = va_arg(args, mode_t);
    va_end(args);
  }
  if (device_index(path) >= 0) return open_device(path, flags);
  return on_real_path(path, [&](const char* p) { return real().openat(dirfd, p, flags, mode); });
}
int openat64(int dirfd, const char* path, int flags, ...) __attribute__((alias("openat")));
int __openat_2(int dirfd, const char* path, int flags) { return openat(dirfd, path, flags); }
int __openat64_2(int dirfd, const char* path, int flags) { return openat(dirfd, path, flags); }

int close(int fd) {
  if (Devices::get().owns(fd)) return Devices::get().io()->close(fd);
  return real().close(fd);
}

int ioctl(int fd, unsigned long request, ...) {
  va_list args;
  va_start(args, request);
  void* arg = va_arg(args, void*);
  va_end(args);
  if (Devices::get().owns(fd)) return device_ioctl(fd, request, arg);
  return real().ioctl(fd, request, arg);
}

void* mmap(void* address, size_t length, int prot, int flags, int fd, off_t offset) {
  if (fd >= 0 && Devices::get().owns(fd)) return Devices::get().io()->mmap(length, prot, flags, fd, offset);
  return real().mmap(address, length, prot, flags, fd, offset);
}
void* mmap64(void* address, size_t length, int prot, int flags, int fd, off_t offset) __attribute__((alias("mmap")));

int munmap(void* address, size_t length) {
  if (Devices::get().owns_mapping(address)) return Devices::get().io()->munmap(address, length);
  return real().munmap(address, length);
}

int poll(pollfd* fds, nfds_t count, int timeout_ms) {
  bool any_device = false;
  for (nfds_t i = 0; i < count; ++i) any_device |= Devices::get().owns(fds[i].fd);
  if (!any_device) return real().poll(fds, count, timeout_ms);
  return Devices::get().io()->poll(fds, count, timeout_ms);
}
int __poll_chk(pollfd* fds, nfds_t count, int timeout_ms, size_t) { return poll(fds, count, timeout_ms); }

int select(int nfds, fd_set* readfds, fd_set* writefds, fd_set* exceptfds, timeval* timeout) {
  bool any_device = false;
  for (int fd = 0; fd < nfds; ++fd)
    if ((readfds && FD_ISSET(fd, readfds)) || (writefds && FD_ISSET(fd, writefds)) ||
        (exceptfds && FD_ISSET(fd, exceptfds)))
      any_device |= Devices::get().owns(fd);
  if (!any_device) return real().select(nfds, readfds, writefds, exceptfds, timeout);
  std::vector<pollfd> fds;
  for (int fd = 0; fd < nfds; ++fd) {
    short events = 0;
    if (readfds && FD_ISSET(fd, readfds)) events |= POLLIN;
    if (writefds && FD_ISSET(fd, writefds)) events |= POLLOUT;
    if (exceptfds && FD_ISSET(fd, exceptfds)) events |= POLLPRI;
    if (events) fds.push_back({fd, events, 0});
  }
  const int timeout_ms = timeout ? static_cast<int>(timeout->tv_sec * 1000 + timeout->tv_usec / 1000) : -1;
  const int ready = Devices::get().io()->poll(fds.data(), fds.size(), timeout_ms);
  if (ready < 0) return -1;
  if (readfds) FD_ZERO(readfds);
  if (writefds) FD_ZERO(writefds);
  if (exceptfds) FD_ZERO(exceptfds);
  int bits = 0;
  for (const auto& p : fds) {
    if (readfds && (p.revents & (POLLIN | POLLERR | POLLHUP))) { FD_SET(p.fd, readfds); ++bits; }
    if (writefds && (p.revents & (POLLOUT | POLLERR))) { FD_SET(p.fd, writefds); ++bits; }
    if (exceptfds && (p.revents & POLLPRI)) { FD_SET(p.fd, exceptfds); ++bits; }
  }
  return bits;
}

int fstat(int fd, struct stat* st) {
  if (Devices::get().owns(fd)) {
    fill_device_stat(fd_device_index(fd), st);
    return 0;
  }
  return real().fstat(fd, st);
}
// struct stat64 is struct stat on 64-bit glibc.
int fstat64(int fd, struct stat64* st) { return fstat(fd, reinterpret_cast<struct stat*>(st)); }

int stat(const char* path, struct stat* st) {
  return stat_path(path, st, [&](const char* p) { return real().stat(p, st); });
}
int stat64(const char* path, struct stat64* st) { return stat(path, reinterpret_cast<struct stat*>(st)); }

int lstat(const char* path, struct stat* st) {
  return stat_path(path, st, [&](const char* p) { return real().lstat(p, st); });
}
int lstat64(const char* path, struct stat64* st) { return lstat(path, reinterpret_cast<struct stat*>(st)); }

int fstatat(int dirfd, const char* path, struct stat* st, int flags) {
  return stat_path(path, st, [&](const char* p) { return real().fstatat(dirfd, p, st, flags); });
}
int fstatat64(int dirfd, const char* path, struct stat64* st, int flags) {
  return fstatat(dirfd, path, reinterpret_cast<struct stat*>(st), flags);
}

int access(const char* path, int mode) {
  if (device_index(path) >= 0) return 0;
  return on_real_path(path, [&](const char* p) { return real().access(p, mode); });
}

}  // extern "C"
