// The client side of the vcam broker (mock_device/broker/vcam_broker.h), inside the
// preload library: every open of a virtual node becomes a connection to the broker, and
// the fd the application gets is, for a video node, that file's readiness eventfd, so
// poll, select and epoll on it work without interposition; for a media node, an open
// file description of the node's memfd (lockf works across processes; no mmap). ioctls are
// marshalled with the kernel's copy semantics (EFAULT for a bad pointer, the struct written back
// for _IOR ioctls, the arrays an ioctl points to copied both ways, the arrays the broker sizes
// (media topology) written where the caller pointed); mmap maps the buffer memfd the broker sends;
// blocking DQBUF waits here on the readiness fd, never in the broker.
//
// dup/dup2/dup3/F_DUPFD make another fd for the same open file; the file closes with
// its last fd, as in the kernel. A process that forks with a virtual device open shares
// the connection with its child: requests from both may interleave (not supported).
//
// Thread-safe. Never calls an interposed entry point (real_libc.h).
#pragma once

#include <poll.h>
#include <signal.h>
#include <sys/types.h>

#include <atomic>
#include <map>
#include <memory>
#include <mutex>
#include <vector>

#include "mock_device/broker/broker_protocol.h"
#include "mock_device/preload/real_libc.h"

namespace camlab::mock::preload {

namespace broker = camlab::mock::broker;

class RemoteFile {
 public:
  RemoteFile(RealFd socket, broker::NodeKind kind, int index)
      : socket_(std::move(socket)), kind_(kind), index_(index) {}
  RemoteFile(const RemoteFile&) = delete;
  RemoteFile& operator=(const RemoteFile&) = delete;
  // The last close, as the kernel's: the broker has released the file (the buffers freed,
  // the queue given up) before this returns, so an open right after finds the device
  // free. Not when a child may share the connection (after fork): then a plain close.
  ~RemoteFile();
  // A fork happened while this file was open: a child may hold the connection too.
  void mark_shared() { shared_with_child_ = true; }

  broker::NodeKind kind() const { return kind_; }
  int index() const { return index_; }

  // ioctl(2) on the file whose application fd is `fd`: the result, or -1 with errno.
  int ioctl(int fd, unsigned long request, void* user_arg);
  // Maps the buffer at `offset`; MAP_FAILED with errno on failure.
  void* mmap(void* address, size_t length, int prot, int flags, off_t offset);
  void unmapped(off_t offset);
  // poll(2)'s revents for `requested`, now; POLLERR|POLLHUP when the broker is gone.
  short poll_events(short requested);

 private:
  // Sends one request and waits for its reply (serialised per file: the broker answers
  // each connection in order). Returns the reply's result (>= 0 or -errno).
  // `cloexec`: whether the fds received are close-on-exec.
  int transact(const std::vector<uint8_t>& request, int fd_in, std::vector<uint8_t>* reply,
               std::vector<RealFd>* fds_out, bool cloexec = true);
  int header_only_request(const broker::RequestHeader& header, std::vector<uint8_t>* reply);
  int ioctl_once(unsigned long request, void* user_arg);

  RealFd socket_;  // the connection to the broker: the open file, closed with it
  std::atomic<bool> shared_with_child_{false};
  broker::NodeKind kind_;
  int index_;
  std::mutex mutex_;
};

class BrokerClient {
 public:
  static BrokerClient& get();

  // Opens virtual node `index` of `kind`: the new fd, or -1 with errno.
  int open(broker::NodeKind kind, int index, int flags);
  // The open file behind an application fd, or null. Cheap when nothing is open.
  std::shared_ptr<RemoteFile> find(int fd) const;
  bool owns(int fd) const {
    return open_fds_.load(std::memory_order_relaxed) > 0 && find(fd) != nullptr;
  }
  // Forgets `fd` (it was closed or replaced); the file closes with its last fd.
  void forget(int fd);
  // `new_fd` now also refers to `file` (dup family).
  void alias(int new_fd, std::shared_ptr<RemoteFile> file);

  void* mmap(const std::shared_ptr<RemoteFile>& file, void* address, size_t length, int prot,
             int flags, off_t offset);
  bool owns_mapping(void* address) const;
  int munmap(void* address, size_t length);

  // poll(2)/ppoll(2) over any mix of fds. timeout: null waits forever.
  int poll(pollfd* fds, nfds_t count, const timespec* timeout, const sigset_t* mask);

  // Every open file may be shared with a child (called after fork, in the parent).
  void mark_all_shared();

 private:
  struct Mapping {
    std::weak_ptr<RemoteFile> file;
    off_t offset;
  };
  mutable std::mutex mutex_;
  std::map<int, std::shared_ptr<RemoteFile>> files_;  // application fd -> open file
  std::atomic<int> open_fds_{0};
  std::atomic<int> mappings_count_{0};
  std::map<void*, Mapping> mappings_;
};

}  // namespace camlab::mock::preload
