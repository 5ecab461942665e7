// libcamlab_vcam_preload.so: the virtual camera as /dev/video0.. and its media
// controller node /dev/media0.. for an unmodified V4L2 or libcamera client, in user space (the
// machines camlab is tested on have no kernel media support).
//
// Loaded with LD_PRELOAD by `camlab vcam run`, it interposes the libc entry points a
// V4L2 client uses on a device: open/openat (and their 64 and fortified forms), close,
// dup/dup2/dup3/fcntl(F_DUPFD), ioctl, mmap/munmap, read/write, poll/ppoll/select/
// pselect (and _chk forms), the stat family and glibc's old __xstat forms (a character
// device, 81:N or 236:N), access, realpath, fopen/readlink/getxattr/listxattr (a fake
// sysfs; relative *at() paths too), and syscall() for the same calls, because libv4l2 and libcamera
// make some of them through syscall() directly. ioctl requests are read as 32 bits, as the kernel
// reads them. It also hides udev's monitor from libcamera (udev_monitor_new_from_netlink), so that
// libcamera enumerates through the fake sysfs.
//
// The devices live in the broker (the `camlab vcam run` process, CAMLAB_VCAM_BROKER);
// this library is its thin client (broker_client.h), so every process of the run sees
// the same devices. Everything that is not a virtual node or a fake sysfs path goes
// straight to the next definition (real_libc.h).
//
// The directory entry points (listings that show the cameras) are in
// directory_entry_points.cpp.
//
// Configuration (environment, set by `camlab vcam run`): CAMLAB_VCAM_BROKER (socket),
// CAMLAB_VCAM_COUNT (devices), CAMLAB_VCAM_SYSFS (the fake sysfs tree), CAMLAB_VCAM_UDEV
// (the fake udev database).
#include <fcntl.h>
#include <linux/videodev2.h>
#include <poll.h>
#include <stdarg.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <sys/select.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <sys/sysmacros.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <climits>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "mock_device/preload/broker_client.h"
#include "mock_device/preload/real_libc.h"
#include "mock_device/preload/sysfs_paths.h"
#include "mock_device/v4l2/fake_sysfs.h"

namespace {

using camlab::mock::broker::NodeKind;
using camlab::mock::preload::BrokerClient;
using camlab::mock::preload::real;
using camlab::mock::preload::RemoteFile;

struct Node {
  NodeKind kind;
  int index;
};

// The virtual node a path names, if any: /dev/videoN or /dev/mediaN for N below
// CAMLAB_VCAM_COUNT, or (`follow`: for the calls that follow links) a /dev/v4l link to one.
bool virtual_node(const char* path, Node* node, bool follow = true) {
  if (!path) return false;
  std::string storage;
  if (follow)
    if (const char* device = camlab::mock::preload::device_behind_v4l_link(path, &storage))
      path = device;
  NodeKind kind;
  if (std::strncmp(path, "/dev/video", 10) == 0)
    kind = NodeKind::kVideo;
  else if (std::strncmp(path, "/dev/media", 10) == 0)
    kind = NodeKind::kMedia;
  else
    return false;
  const char* digits = path + 10;
  if (!*digits || std::strlen(digits) > 6) return false;
  for (const char* p = digits; *p; ++p)
    if (*p < '0' || *p > '9') return false;
  const int index = std::atoi(digits);
  if (index >= camlab::mock::preload::vcam_count()) return false;
  *node = {kind, index};
  return true;
}

// The node's device number: 81:N (VIDEO_MAJOR) or kMediaMajor:N.
unsigned node_major(const Node& node) {
  return node.kind == NodeKind::kMedia ? camlab::mock::kMediaMajor : camlab::mock::kVideoMajor;
}

void fill_node_stat(const Node& node, struct stat* st) {
  std::memset(st, 0, sizeof *st);
  st->st_mode = S_IFCHR | 0660;
  st->st_rdev = makedev(node_major(node), static_cast<unsigned>(node.index));
  st->st_nlink = 1;
  st->st_blksize = 4096;
}

// Calls `call` with the path the client's path stands for: fake sysfs paths are
// redirected into the fake tree, every other path passes unchanged.
template <class Call>
auto on_real_path(const char* path, Call call) {
  std::string storage;
  const char* redirected = camlab::mock::preload::redirect_sysfs_path(path, &storage);
  return call(redirected ? redirected : path);
}
// The same for the *at() calls, whose relative path may step from a real folder into a
// fake tree (libudev walks /sys one name at a time). A redirected path is absolute, so
// `dirfd` no longer matters for it.
template <class Call>
auto on_real_path_at(int dirfd, const char* path, Call call) {
  std::string storage;
  const char* redirected = camlab::mock::preload::redirect_sysfs_path_at(dirfd, path, &storage);
  return call(redirected ? redirected : path);
}

template <class Call>
int stat_path(const char* path, struct stat* st, Call call, bool follow = true) {
  if (Node node; virtual_node(path, &node, follow)) {
    fill_node_stat(node, st);
    return 0;
  }
  return on_real_path(path, call);
}

// A /proc link (an fd's or the working folder's) that resolves inside the fake sysfs is
// reported under /sys, as realpath is: libudev takes a device's path from the fd it
// walked to (/proc/self/fd/N) and refuses one outside /sys. `n` is readlink's result,
// the new length is returned.
ssize_t proc_link_under_sys(const char* path, char* buffer, ssize_t n) {
  if (n <= 0 || !path || std::strncmp(path, "/proc/", 6) != 0) return n;
  char resolved[PATH_MAX];
  const size_t length = std::min(static_cast<size_t>(n), sizeof resolved - 1);
  std::memcpy(resolved, buffer, length);
  resolved[length] = '\0';
  camlab::mock::preload::unredirect_sysfs_path(resolved);
  const size_t shorter = std::strlen(resolved);
  if (shorter == length) return n;
  std::memcpy(buffer, resolved, shorter);  // never longer: no terminator, as readlink
  return static_cast<ssize_t>(shorter);
}

int open_path(const char* path, int flags, mode_t mode, int dirfd, bool at) {
  if (Node node; virtual_node(path, &node))
    return BrokerClient::get().open(node.kind, node.index, flags);
  if (at)
    return on_real_path_at(dirfd, path,
                           [&](const char* p) { return real().openat(dirfd, p, flags, mode); });
  return on_real_path(path, [&](const char* p) { return real().open(p, flags, mode); });
}

int ioctl_fd(int fd, unsigned long request, void* arg) {
  // The kernel reads the request's low 32 bits: programs that pass it as an int (ustreamer,
  // motion) hand VIDIOC_QUERYCAP over sign-extended, 0xffffffff80685600.
  if (auto file = BrokerClient::get().find(fd))
    return file->ioctl(fd, static_cast<uint32_t>(request), arg);
  return real().ioctl(fd, request, arg);
}

int close_fd(int fd) {
  BrokerClient::get().forget(fd);
  return real().close(fd);
}

// dup family: the new fd is another name of the same open file.
int after_dup(int old_fd, int new_fd) {
  if (new_fd < 0) return new_fd;
  if (auto file = BrokerClient::get().find(old_fd))
    BrokerClient::get().alias(new_fd, std::move(file));
  return new_fd;
}
int dup2_fd(int old_fd, int new_fd, int flags, bool three) {
  // dup2 onto an open virtual fd closes that file first, as the kernel does.
  if (old_fd != new_fd) BrokerClient::get().forget(new_fd);
  return after_dup(old_fd,
                   three ? real().dup3(old_fd, new_fd, flags) : real().dup2(old_fd, new_fd));
}

int fcntl_fd(int fd, int command, long arg) {
  const int result = real().fcntl(fd, command, arg);
  if (command == F_DUPFD || command == F_DUPFD_CLOEXEC) return after_dup(fd, result);
  return result;
}

ssize_t read_fd(int fd, void* buffer, size_t size) {
  // The device has no read() I/O (no V4L2_CAP_READWRITE); reading the readiness eventfd
  // would break its signalling.
  if (BrokerClient::get().owns(fd)) {
    errno = EINVAL;
    return -1;
  }
  return real().read(fd, buffer, size);
}
ssize_t write_fd(int fd, const void* buffer, size_t size) {
  if (BrokerClient::get().owns(fd)) {
    errno = EINVAL;
    return -1;
  }
  return real().write(fd, buffer, size);
}

void* mmap_fd(void* address, size_t length, int prot, int flags, int fd, off_t offset) {
  if (fd >= 0)
    if (auto file = BrokerClient::get().find(fd))
      return BrokerClient::get().mmap(file, address, length, prot, flags, offset);
  return real().mmap(address, length, prot, flags, fd, offset);
}

int munmap_address(void* address, size_t length) {
  if (BrokerClient::get().owns_mapping(address)) return BrokerClient::get().munmap(address, length);
  return real().munmap(address, length);
}

int select_fds(int nfds, fd_set* readfds, fd_set* writefds, fd_set* exceptfds,
               const timespec* timeout, const sigset_t* mask, bool microseconds,
               timeval* timeout_us) {
  std::vector<pollfd> fds;
  bool any_device = false;
  for (int fd = 0; fd < nfds && fd < FD_SETSIZE; ++fd) {
    short events = 0;
    if (readfds && FD_ISSET(fd, readfds)) events |= POLLIN;
    if (writefds && FD_ISSET(fd, writefds)) events |= POLLOUT;
    if (exceptfds && FD_ISSET(fd, exceptfds)) events |= POLLPRI;
    if (!events) continue;
    fds.push_back({fd, events, 0});
    any_device |= BrokerClient::get().owns(fd);
  }
  if (!any_device) {
    if (microseconds) return real().select(nfds, readfds, writefds, exceptfds, timeout_us);
    return real().pselect(nfds, readfds, writefds, exceptfds, timeout, mask);
  }
  const int ready = BrokerClient::get().poll(fds.data(), fds.size(), timeout, mask);
  if (ready < 0) return -1;
  if (readfds) FD_ZERO(readfds);
  if (writefds) FD_ZERO(writefds);
  if (exceptfds) FD_ZERO(exceptfds);
  int bits = 0;
  for (const auto& p : fds) {
    if (readfds && (p.revents & (POLLIN | POLLERR | POLLHUP))) {
      FD_SET(p.fd, readfds);
      ++bits;
    }
    if (writefds && (p.revents & (POLLOUT | POLLERR))) {
      FD_SET(p.fd, writefds);
      ++bits;
    }
    if (exceptfds && (p.revents & POLLPRI)) {
      FD_SET(p.fd, exceptfds);
      ++bits;
    }
  }
  if (microseconds && timeout_us) *timeout_us = {0, 0};  // Linux updates the remaining time
  return bits;
}

int poll_fds(pollfd* fds, nfds_t count, const timespec* timeout, const sigset_t* mask) {
  return BrokerClient::get().poll(fds, count, timeout, mask);
}

// open(2)'s optional third argument: there only when the flags create a file.
mode_t creation_mode(int flags, va_list args) {
  return (flags & (O_CREAT | O_TMPFILE)) ? va_arg(args, mode_t) : 0;
}

timespec from_ms(int timeout_ms) { return {timeout_ms / 1000, (timeout_ms % 1000) * 1000000L}; }

}  // namespace

// The interposed libc entry points: the only symbols the library exports (it is built
// with hidden visibility), so it takes over exactly these and nothing of its own clashes
// with the program it is loaded into.
#pragma GCC visibility push(default)
extern "C" {

FILE* fopen(const char* path, const char* mode) {
  return on_real_path(path, [&](const char* p) { return real().fopen(p, mode); });
}
FILE* fopen64(const char* path, const char* mode) { return fopen(path, mode); }

ssize_t readlink(const char* path, char* buffer, size_t size) {
  const ssize_t n =
      on_real_path(path, [&](const char* p) { return real().readlink(p, buffer, size); });
  return proc_link_under_sys(path, buffer, n);
}
ssize_t readlinkat(int dirfd, const char* path, char* buffer, size_t size) {
  const ssize_t n = on_real_path_at(
      dirfd, path, [&](const char* p) { return real().readlinkat(dirfd, p, buffer, size); });
  return proc_link_under_sys(path, buffer, n);
}

// Extended attributes (ls -l asks for the SELinux label): the fake trees' files have the
// attributes of the real files they are, the virtual nodes none.
ssize_t getxattr(const char* path, const char* name, void* value, size_t size) {
  if (Node node; virtual_node(path, &node)) return (errno = ENODATA), -1;
  return on_real_path(path, [&](const char* p) { return real().getxattr(p, name, value, size); });
}
ssize_t lgetxattr(const char* path, const char* name, void* value, size_t size) {
  if (Node node; virtual_node(path, &node)) return (errno = ENODATA), -1;
  return on_real_path(path, [&](const char* p) { return real().lgetxattr(p, name, value, size); });
}
ssize_t listxattr(const char* path, char* list, size_t size) {
  if (Node node; virtual_node(path, &node)) return 0;
  return on_real_path(path, [&](const char* p) { return real().listxattr(p, list, size); });
}
ssize_t llistxattr(const char* path, char* list, size_t size) {
  if (Node node; virtual_node(path, &node)) return 0;
  return on_real_path(path, [&](const char* p) { return real().llistxattr(p, list, size); });
}

char* realpath(const char* path, char* resolved) {
  std::string device;
  if (const char* behind = camlab::mock::preload::device_behind_v4l_link(path, &device))
    path = behind;
  if (Node node; virtual_node(path, &node)) {
    if (!resolved && !(resolved = static_cast<char*>(std::malloc(PATH_MAX)))) return nullptr;
    std::strncpy(resolved, path, PATH_MAX - 1);
    resolved[PATH_MAX - 1] = '\0';
    return resolved;
  }
  char* result = on_real_path(path, [&](const char* p) { return real().realpath(p, resolved); });
  // A path resolved inside the fake tree is reported where the client looked: /sys/...
  if (result) camlab::mock::preload::unredirect_sysfs_path(result);
  return result;
}
char* __realpath_chk(const char* path, char* resolved, size_t) { return realpath(path, resolved); }

int open(const char* path, int flags, ...) {
  va_list args;
  va_start(args, flags);
  const mode_t mode = creation_mode(flags, args);
  va_end(args);
  return open_path(path, flags, mode, AT_FDCWD, false);
}
int open64(const char* path, int flags, ...) __attribute__((alias("open")));
int __open_2(const char* path, int flags) { return open_path(path, flags, 0, AT_FDCWD, false); }
int __open64_2(const char* path, int flags) { return open_path(path, flags, 0, AT_FDCWD, false); }

int openat(int dirfd, const char* path, int flags, ...) {
  va_list args;
  va_start(args, flags);
  const mode_t mode = creation_mode(flags, args);
  va_end(args);
  return open_path(path, flags, mode, dirfd, true);
}
int openat64(int dirfd, const char* path, int flags, ...) __attribute__((alias("openat")));
int __openat_2(int dirfd, const char* path, int flags) {
  return open_path(path, flags, 0, dirfd, true);
}
int __openat64_2(int dirfd, const char* path, int flags) {
  return open_path(path, flags, 0, dirfd, true);
}

int close(int fd) { return close_fd(fd); }

int dup(int fd) { return after_dup(fd, real().dup(fd)); }
int dup2(int old_fd, int new_fd) { return dup2_fd(old_fd, new_fd, 0, false); }
int dup3(int old_fd, int new_fd, int flags) { return dup2_fd(old_fd, new_fd, flags, true); }

int fcntl(int fd, int command, ...) {
  va_list args;
  va_start(args, command);
  const long arg = va_arg(args, long);
  va_end(args);
  return fcntl_fd(fd, command, arg);
}
int fcntl64(int fd, int command, ...) __attribute__((alias("fcntl")));

int ioctl(int fd, unsigned long request, ...) {
  va_list args;
  va_start(args, request);
  void* arg = va_arg(args, void*);
  va_end(args);
  return ioctl_fd(fd, request, arg);
}

ssize_t read(int fd, void* buffer, size_t size) { return read_fd(fd, buffer, size); }
ssize_t __read_chk(int fd, void* buffer, size_t size, size_t) { return read_fd(fd, buffer, size); }
ssize_t write(int fd, const void* buffer, size_t size) { return write_fd(fd, buffer, size); }

void* mmap(void* address, size_t length, int prot, int flags, int fd, off_t offset) {
  return mmap_fd(address, length, prot, flags, fd, offset);
}
void* mmap64(void* address, size_t length, int prot, int flags, int fd, off_t offset)
    __attribute__((alias("mmap")));
int munmap(void* address, size_t length) { return munmap_address(address, length); }

int poll(pollfd* fds, nfds_t count, int timeout_ms) {
  if (timeout_ms < 0) return poll_fds(fds, count, nullptr, nullptr);
  const timespec timeout = from_ms(timeout_ms);
  return poll_fds(fds, count, &timeout, nullptr);
}
int __poll_chk(pollfd* fds, nfds_t count, int timeout_ms, size_t) {
  return poll(fds, count, timeout_ms);
}
int ppoll(pollfd* fds, nfds_t count, const timespec* timeout, const sigset_t* mask) {
  return poll_fds(fds, count, timeout, mask);
}
int __ppoll_chk(pollfd* fds, nfds_t count, const timespec* timeout, const sigset_t* mask, size_t) {
  return poll_fds(fds, count, timeout, mask);
}

int select(int nfds, fd_set* readfds, fd_set* writefds, fd_set* exceptfds, timeval* timeout) {
  timespec t{};
  if (timeout) t = {timeout->tv_sec, timeout->tv_usec * 1000L};
  return select_fds(nfds, readfds, writefds, exceptfds, timeout ? &t : nullptr, nullptr, true,
                    timeout);
}
int pselect(int nfds, fd_set* readfds, fd_set* writefds, fd_set* exceptfds, const timespec* timeout,
            const sigset_t* mask) {
  return select_fds(nfds, readfds, writefds, exceptfds, timeout, mask, false, nullptr);
}

int fstat(int fd, struct stat* st) {
  if (auto file = BrokerClient::get().find(fd)) {
    fill_node_stat({file->kind(), file->index()}, st);
    return 0;
  }
  return real().fstat(fd, st);
}
// struct stat64 is struct stat on 64-bit glibc.
int fstat64(int fd, struct stat64* st) { return fstat(fd, reinterpret_cast<struct stat*>(st)); }

int stat(const char* path, struct stat* st) {
  return stat_path(path, st, [&](const char* p) { return real().stat(p, st); });
}
int stat64(const char* path, struct stat64* st) {
  return stat(path, reinterpret_cast<struct stat*>(st));
}

int lstat(const char* path, struct stat* st) {
  return stat_path(
      path, st, [&](const char* p) { return real().lstat(p, st); }, false);
}
int lstat64(const char* path, struct stat64* st) {
  return lstat(path, reinterpret_cast<struct stat*>(st));
}

int fstatat(int dirfd, const char* path, struct stat* st, int flags) {
  // fstatat(fd, "", st, AT_EMPTY_PATH) is fstat(fd).
  if (path[0] == '\0' && (flags & AT_EMPTY_PATH)) return fstat(dirfd, st);
  if (Node node; virtual_node(path, &node, !(flags & AT_SYMLINK_NOFOLLOW))) {
    fill_node_stat(node, st);
    return 0;
  }
  return on_real_path_at(dirfd, path,
                         [&](const char* p) { return real().fstatat(dirfd, p, st, flags); });
}
int fstatat64(int dirfd, const char* path, struct stat64* st, int flags) {
  return fstatat(dirfd, path, reinterpret_cast<struct stat*>(st), flags);
}

// glibc before 2.33 compiled stat() and friends into these (programs built then, such as
// fswebcam, still call them); `version` names the struct stat layout, which on x86-64 and
// arm64 is the one struct stat has.
int __xstat(int, const char* path, struct stat* st) { return stat(path, st); }
int __xstat64(int, const char* path, struct stat64* st) { return stat64(path, st); }
int __lxstat(int, const char* path, struct stat* st) { return lstat(path, st); }
int __lxstat64(int, const char* path, struct stat64* st) { return lstat64(path, st); }
int __fxstat(int, int fd, struct stat* st) { return fstat(fd, st); }
int __fxstat64(int, int fd, struct stat64* st) { return fstat64(fd, st); }
int __fxstatat(int, int dirfd, const char* path, struct stat* st, int flags) {
  return fstatat(dirfd, path, st, flags);
}
int __fxstatat64(int, int dirfd, const char* path, struct stat64* st, int flags) {
  return fstatat64(dirfd, path, st, flags);
}

int statx(int dirfd, const char* path, int flags, unsigned mask, struct statx* out) {
  Node node;
  const bool by_fd = path[0] == '\0' && (flags & AT_EMPTY_PATH);
  std::shared_ptr<RemoteFile> file = by_fd ? BrokerClient::get().find(dirfd) : nullptr;
  if (file) node = {file->kind(), file->index()};
  if (file || (!by_fd && virtual_node(path, &node, !(flags & AT_SYMLINK_NOFOLLOW)))) {
    std::memset(out, 0, sizeof *out);
    out->stx_mask = STATX_TYPE | STATX_MODE | STATX_NLINK;
    out->stx_mode = S_IFCHR | 0660;
    out->stx_nlink = 1;
    out->stx_blksize = 4096;
    out->stx_rdev_major = node_major(node);
    out->stx_rdev_minor = static_cast<uint32_t>(node.index);
    return 0;
  }
  return on_real_path_at(dirfd, path,
                         [&](const char* p) { return real().statx(dirfd, p, flags, mask, out); });
}

int access(const char* path, int mode) {
  if (Node node; virtual_node(path, &node)) return 0;
  return on_real_path(path, [&](const char* p) { return real().access(p, mode); });
}
int faccessat(int dirfd, const char* path, int mode, int flags) {
  if (Node node; virtual_node(path, &node)) return 0;
  return on_real_path_at(dirfd, path,
                         [&](const char* p) { return real().faccessat(dirfd, p, mode, flags); });
}

// libv4l2 and libcamera call some system calls through syscall() directly. Those on a
// virtual node or a fake sysfs path come here; every other goes to the real syscall().
long syscall(long number, ...) {
  va_list args;
  va_start(args, number);
  long a[6];
  for (long& v : a) v = va_arg(args, long);
  va_end(args);
  auto ptr = [&](int i) { return reinterpret_cast<void*>(a[i]); };
  auto str = [&](int i) { return reinterpret_cast<const char*>(a[i]); };
  switch (number) {
    case SYS_open:
      return open_path(str(0), static_cast<int>(a[1]), static_cast<mode_t>(a[2]), AT_FDCWD, false);
    case SYS_openat:
      return open_path(str(1), static_cast<int>(a[2]), static_cast<mode_t>(a[3]),
                       static_cast<int>(a[0]), true);
    case SYS_close:
      return close_fd(static_cast<int>(a[0]));
    case SYS_ioctl:
      return ioctl_fd(static_cast<int>(a[0]), static_cast<unsigned long>(a[1]), ptr(2));
    case SYS_dup:
      return after_dup(static_cast<int>(a[0]), real().dup(static_cast<int>(a[0])));
    case SYS_dup2:
      return dup2_fd(static_cast<int>(a[0]), static_cast<int>(a[1]), 0, false);
    case SYS_dup3:
      return dup2_fd(static_cast<int>(a[0]), static_cast<int>(a[1]), static_cast<int>(a[2]), true);
    case SYS_fcntl:
      return fcntl_fd(static_cast<int>(a[0]), static_cast<int>(a[1]), a[2]);
    case SYS_read:
      return read_fd(static_cast<int>(a[0]), ptr(1), static_cast<size_t>(a[2]));
    case SYS_write:
      return write_fd(static_cast<int>(a[0]), ptr(1), static_cast<size_t>(a[2]));
    case SYS_mmap:
      return reinterpret_cast<long>(mmap_fd(ptr(0), static_cast<size_t>(a[1]),
                                            static_cast<int>(a[2]), static_cast<int>(a[3]),
                                            static_cast<int>(a[4]), a[5]));
    case SYS_munmap:
      return munmap_address(ptr(0), static_cast<size_t>(a[1]));
    case SYS_poll: {
      const int timeout_ms = static_cast<int>(a[2]);
      const timespec timeout = from_ms(timeout_ms);
      return poll_fds(static_cast<pollfd*>(ptr(0)), static_cast<nfds_t>(a[1]),
                      timeout_ms < 0 ? nullptr : &timeout, nullptr);
    }
    case SYS_ppoll:
      return poll_fds(static_cast<pollfd*>(ptr(0)), static_cast<nfds_t>(a[1]),
                      static_cast<const timespec*>(ptr(2)), static_cast<const sigset_t*>(ptr(3)));
    case SYS_fstat:
      return fstat(static_cast<int>(a[0]), static_cast<struct stat*>(ptr(1)));
    case SYS_newfstatat:
      return fstatat(static_cast<int>(a[0]), str(1), static_cast<struct stat*>(ptr(2)),
                     static_cast<int>(a[3]));
    case SYS_statx:
      return statx(static_cast<int>(a[0]), str(1), static_cast<int>(a[2]),
                   static_cast<unsigned>(a[3]), static_cast<struct statx*>(ptr(4)));
    default:
      return real().syscall(number, a[0], a[1], a[2], a[3], a[4], a[5]);
  }
}

// libcamera enumerates through udev when it can, which needs the kernel's devices (and
// a mount namespace to fake them). No udev monitor makes it fall back to its sysfs
// enumerator, which reads the fake tree.
struct udev;
struct udev_monitor;
udev_monitor* udev_monitor_new_from_netlink(udev*, const char*) {
  errno = ENOSYS;
  return nullptr;
}

}  // extern "C"
#pragma GCC visibility pop
