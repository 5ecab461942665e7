// The wire protocol between the vcam broker (the process that owns the virtual devices,
// mock_device/broker/vcam_broker.h) and its clients (the preload library in every
// process of `camlab vcam run`).
//
// One AF_UNIX SOCK_SEQPACKET connection per open file: the first message opens a device
// node, every later one is a request on that open file, and closing the connection is
// close(2) on it. So a client that dies releases its file (and its buffer queue) exactly
// as the kernel releases a dead process's files.
//
// A request is a RequestHeader, the ioctl argument struct (arg_size bytes), then
// user_buffer_count UserBuffer descriptors and their bytes: the arrays an ioctl struct
// points to (v4l2_ext_controls::controls, media topology arrays), which the broker
// rebuilds in its own memory and patches into the struct. File descriptors travel as
// SCM_RIGHTS: the device's readiness eventfd on open (a video node) or the node's memfd
// (a media node: its own open file description of one memfd per node, so lockf(2)
// between processes works as on the kernel's device inode), a buffer's memfd on mmap,
// the fd of VIDIOC_EXPBUF (out) and of a DMABUF VIDIOC_QBUF (in).
//
// Arrays whose size only the device knows (the media topology arrays: MEDIA_IOC_ENUM_LINKS
// carries no counts) are not sent; the broker fills them in its own memory and returns
// them as copy-out regions: after the reply's body, copy_out_count CopyOut descriptors
// each followed by its bytes, which the client writes at `address` in its own memory
// (EFAULT if it cannot). A reply whose arg_size is 0 does not write the struct back (a
// media ioctl that failed, as in the kernel).
//
// Reentrant.
#pragma once

#include <sys/types.h>

#include <cstddef>
#include <cstdint>
#include <vector>

namespace camlab::mock::broker {

enum class Op : uint32_t {
  kOpen = 1,    // offset = node index, length = node kind, flags = open(2) flags
  kIoctl = 2,   // ioctl_request + argument
  kMmap = 3,    // offset, length: reply carries the buffer's memfd
  kMunmap = 4,  // offset: a mapping made through kMmap went away
  kPoll = 5,    // flags = requested poll events: reply.revents, never blocks
  kFault = 6,   // instead of kOpen: offset = node index, flags = Fault, length = count
};

// Faults a test (or `camlab vcam fault`) can inject into a served device.
enum class Fault : int32_t {
  kUnplug = 1,      // ENODEV from then on
  kDequeueEio = 2,  // the next `count` DQBUFs fail with EIO
  kDropFrames = 3,  // the next `count` frames are dropped (sequence gaps)
  kStall = 4,       // no frames until kResume
  kResume = 5,
  kReplug = 6,  // an unplugged device is plugged in again (a new device; old fds stay dead)
};

enum class NodeKind : uint32_t { kVideo = 0, kMedia = 1 };

inline constexpr uint32_t kNoField = UINT32_MAX;
inline constexpr size_t kMaxArgBytes = 4096;  // largest V4L2/media ioctl struct
inline constexpr size_t kMaxUserBuffers = 8;
inline constexpr size_t kMaxUserBufferBytes = 1 << 20;

struct RequestHeader {
  Op op{};
  uint32_t user_buffer_count = 0;
  uint64_t ioctl_request = 0;
  int64_t offset = 0;
  uint64_t length = 0;
  int32_t flags = 0;
  uint32_t arg_size = 0;
  uint32_t arg_unreadable = 0;          // 1: the client could not read the argument (EFAULT)
  uint32_t fd_field_offset = kNoField;  // where a passed-in fd goes in the struct
};

struct UserBuffer {
  uint32_t pointer_offset = 0;  // of the pointer field inside the ioctl struct
  uint32_t size_bytes = 0;
};

struct ReplyHeader {
  int32_t result = 0;   // >= 0, or -errno
  int32_t revents = 0;  // kPoll
  uint32_t arg_size = 0;
  uint32_t user_buffer_count = 0;
  uint32_t fd_field_offset = kNoField;  // where a passed-out fd goes in the struct
  uint32_t copy_out_count = 0;          // CopyOut regions after the body
};

struct CopyOut {
  uint64_t address = 0;  // in the client's memory (a pointer the client put in the struct)
  uint32_t size_bytes = 0;
  uint32_t reserved = 0;
};
inline constexpr size_t kMaxCopyOuts = 8;

// The arrays `arg` (the ioctl struct, already copied from the caller) points to, that
// the device reads or fills. An error (-EINVAL) when a count is beyond the limits.
int user_buffers_of(unsigned long request, const void* arg, std::vector<UserBuffer>* out);

// Offset of an fd the caller passes in the struct (DMABUF queueing), or kNoField.
uint32_t fd_in_field(unsigned long request, const void* arg);
// Offset of an fd the device returns in the struct (VIDIOC_EXPBUF), or kNoField.
uint32_t fd_out_field(unsigned long request);

// Asks the broker at `socket_path` to inject `fault` into device `index`: 0 or -errno
// (-ENODEV: no such device, -ECONNREFUSED: no broker).
int inject_fault(const char* socket_path, int index, Fault fault, int count = 1);

// One message with up to 4 fds. Returns 0 or -errno. Retries EINTR.
int send_message(int socket, const void* data, size_t size, const int* fds, int fd_count);
// One whole message into `data` and its fds (appended to `fds`; the caller owns them).
// Returns the size, 0 on an orderly shutdown of the peer, or -errno. MSG_CMSG_CLOEXEC
// unless `cloexec` is false.
ssize_t receive_message(int socket, std::vector<uint8_t>* data, std::vector<int>* fds,
                        bool cloexec = true);
// The same, with each received fd given at once to an owner (base/unique_fd.h):
// UniqueFd in the broker, the preload library's RealFd in the clients.
template <class Fd>
ssize_t receive_message(int socket, std::vector<uint8_t>* data, std::vector<Fd>* fds,
                        bool cloexec = true) {
  std::vector<int> received;
  const ssize_t n = receive_message(socket, data, &received, cloexec);
  for (int fd : received) fds->emplace_back(fd);
  return n;
}

}  // namespace camlab::mock::broker
