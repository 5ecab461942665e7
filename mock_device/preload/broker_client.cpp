#include "mock_device/preload/broker_client.h"

#include <fcntl.h>
#include <linux/videodev2.h>
#include <pthread.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <sys/socket.h>
#include <sys/uio.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "mock_device/preload/real_libc.h"

namespace camlab::mock::preload {

namespace {

using broker::Op;
using broker::ReplyHeader;
using broker::RequestHeader;
using broker::UserBuffer;

// Copies between this process's memory and ours with the kernel's EFAULT semantics: a
// bad pointer fails the call instead of crashing the caller.
bool copy_from_user(void* to, const void* from, size_t size) {
  iovec local{to, size}, remote{const_cast<void*>(from), size};
  return process_vm_readv(getpid(), &local, 1, &remote, 1, 0) == static_cast<ssize_t>(size);
}
bool copy_to_user(void* to, const void* from, size_t size) {
  iovec local{const_cast<void*>(from), size}, remote{to, size};
  return process_vm_writev(getpid(), &local, 1, &remote, 1, 0) == static_cast<ssize_t>(size);
}

std::vector<uint8_t> encode(const RequestHeader& header, const void* arg = nullptr,
                            size_t arg_size = 0) {
  std::vector<uint8_t> message(sizeof header + arg_size);
  std::memcpy(message.data(), &header, sizeof header);
  if (arg_size) std::memcpy(message.data() + sizeof header, arg, arg_size);
  return message;
}

int fail(int error) {
  errno = error;
  return -1;
}

// Waits until `fd` (a readiness eventfd) is readable or `timeout_ms` passes.
void wait_readable(int fd, int timeout_ms) {
  pollfd p{fd, POLLIN, 0};
  const timespec t{timeout_ms / 1000, (timeout_ms % 1000) * 1000000L};
  real().ppoll(&p, 1, &t, nullptr);
}

}  // namespace

int RemoteFile::transact(const std::vector<uint8_t>& request, int fd_in,
                         std::vector<uint8_t>* reply, std::vector<RealFd>* fds_out, bool cloexec) {
  std::lock_guard lock(mutex_);
  const int socket = socket_.get();
  if (int error =
          broker::send_message(socket, request.data(), request.size(), &fd_in, fd_in >= 0 ? 1 : 0);
      error < 0)
    return error == -EPIPE || error == -ECONNRESET ? -ENODEV : error;
  const ssize_t n = broker::receive_message(socket, reply, fds_out, cloexec);
  // A broker that went away is a device that went away.
  if (n < static_cast<ssize_t>(sizeof(ReplyHeader)))
    return n < 0 && n != -ECONNRESET ? static_cast<int>(n) : -ENODEV;
  ReplyHeader header;
  std::memcpy(&header, reply->data(), sizeof header);
  return header.result;
}

int RemoteFile::ioctl(int fd, unsigned long request, void* user_arg) {
  for (;;) {
    const int result = ioctl_once(request, user_arg);
    // The broker's side never blocks: a blocking DQBUF waits here for a done buffer
    // (the readiness fd turns readable) and asks again.
    if (!(result < 0 && errno == EAGAIN && request == VIDIOC_DQBUF)) return result;
    if (real().fcntl(fd, F_GETFL) & O_NONBLOCK) return result;
    wait_readable(fd, 100);
  }
}

int RemoteFile::ioctl_once(unsigned long request, void* user_arg) {
  RequestHeader header;
  header.op = Op::kIoctl;
  header.ioctl_request = request;
  const size_t size = _IOC_SIZE(request);
  if (size > broker::kMaxArgBytes) return fail(ENOTTY);
  // Like the kernel's video_usercopy: the struct is copied in whole; an unreadable
  // argument is EFAULT, but only after the device had the chance to say ENOTTY.
  std::vector<uint64_t> arg((size + 7) / 8 + 1);
  if (size > 0 && (user_arg == nullptr || !copy_from_user(arg.data(), user_arg, size))) {
    header.arg_unreadable = 1;
    std::vector<uint8_t> reply;
    const int result = header_only_request(header, &reply);
    return fail(result < 0 ? -result : EFAULT);
  }
  header.arg_size = static_cast<uint32_t>(size);
  std::vector<UserBuffer> buffers;
  if (int error = broker::user_buffers_of(request, arg.data(), &buffers); error < 0)
    return fail(-error);
  header.user_buffer_count = static_cast<uint32_t>(buffers.size());
  std::vector<uint8_t> message = encode(header, arg.data(), size);
  std::vector<void*> user_pointers(buffers.size());
  for (const UserBuffer& b : buffers) {
    const auto* bytes = reinterpret_cast<const uint8_t*>(&b);
    message.insert(message.end(), bytes, bytes + sizeof b);
  }
  for (size_t i = 0; i < buffers.size(); ++i) {
    std::memcpy(&user_pointers[i],
                reinterpret_cast<uint8_t*>(arg.data()) + buffers[i].pointer_offset, sizeof(void*));
    const size_t at = message.size();
    message.resize(at + buffers[i].size_bytes);
    if (!user_pointers[i] ||
        !copy_from_user(message.data() + at, user_pointers[i], buffers[i].size_bytes))
      return fail(EFAULT);
  }
  // A USERPTR buffer must be memory the application has (vb2 pins it at QBUF); the broker
  // cannot see ours, so it is checked here.
  const auto* buffer = reinterpret_cast<const v4l2_buffer*>(arg.data());
  const bool userptr =
      (request == VIDIOC_QBUF || request == VIDIOC_DQBUF) && buffer->memory == V4L2_MEMORY_USERPTR;
  uint8_t probe = 0;
  if (userptr && request == VIDIOC_QBUF && buffer->m.userptr != 0 && buffer->length > 0 &&
      (!copy_from_user(&probe, reinterpret_cast<const void*>(buffer->m.userptr), 1) ||
       !copy_from_user(&probe,
                       reinterpret_cast<const void*>(buffer->m.userptr + buffer->length - 1), 1)))
    return fail(EFAULT);
  int fd_in = -1;
  if (const uint32_t field = broker::fd_in_field(request, arg.data()); field != broker::kNoField)
    std::memcpy(&fd_in, reinterpret_cast<uint8_t*>(arg.data()) + field, sizeof fd_in);

  // An exported buffer's fd (EXPBUF) is close-on-exec only when asked for.
  bool cloexec = true;
  if (request == VIDIOC_EXPBUF)
    cloexec = (reinterpret_cast<const v4l2_exportbuffer*>(arg.data())->flags & O_CLOEXEC) != 0;

  std::vector<uint8_t> reply;
  std::vector<RealFd> fds;
  const int result = transact(message, fd_in, &reply, &fds, cloexec);
  ReplyHeader out;
  if (reply.size() >= sizeof out) std::memcpy(&out, reply.data(), sizeof out);
  size_t at = sizeof out;
  const bool has_body =
      reply.size() >= sizeof out && out.arg_size == size && reply.size() >= at + size;
  int error = result < 0 ? -result : 0;
  if (has_body) {
    std::memcpy(arg.data(), reply.data() + at, size);
    at += size;
    // The arrays first (the struct written back keeps the caller's own pointers).
    for (size_t i = 0; i < buffers.size() && i < out.user_buffer_count; ++i) {
      if (reply.size() < at + buffers[i].size_bytes) break;
      if (!copy_to_user(user_pointers[i], reply.data() + at, buffers[i].size_bytes)) error = EFAULT;
      at += buffers[i].size_bytes;
    }
  }
  // Arrays the broker sized and filled (media topology): each goes to the address the
  // caller gave for it; also after a failure (ENOSPC), as the kernel copies them.
  bool copied_out = true;
  for (uint32_t i = 0;
       reply.size() >= sizeof out && i < out.copy_out_count && i < broker::kMaxCopyOuts; ++i) {
    broker::CopyOut region;
    if (reply.size() < at + sizeof region) break;
    std::memcpy(&region, reply.data() + at, sizeof region);
    at += sizeof region;
    if (reply.size() < at + region.size_bytes) break;
    if (!copy_to_user(reinterpret_cast<void*>(region.address), reply.data() + at,
                      region.size_bytes))
      copied_out = false;
    at += region.size_bytes;
  }
  if (!copied_out) error = EFAULT;
  if (has_body && copied_out) {
    // An fd the device handed out (EXPBUF) becomes one of ours.
    if (out.fd_field_offset != broker::kNoField && out.fd_field_offset + sizeof(int) <= size) {
      const int fd = fds.empty() ? -1 : fds[0].release();  // the application's now
      std::memcpy(reinterpret_cast<uint8_t*>(arg.data()) + out.fd_field_offset, &fd, sizeof fd);
      if (!fds.empty()) fds.erase(fds.begin());
    }
    // A dequeued USERPTR buffer: the frame from the memfd that came with the reply to the
    // application's pointer, as uvcvideo copies it into the buffer.
    if (userptr && request == VIDIOC_DQBUF && result >= 0) {
      const size_t bytes = buffer->bytesused;
      if (fds.empty() || ::pread(fds[0].get(), reinterpret_cast<void*>(buffer->m.userptr), bytes,
                                 0) != static_cast<ssize_t>(bytes))
        error = EFAULT;
    }
    // Like the kernel, write the struct back for _IOR and _IOWR ioctls (error_idx and
    // friends are reported on failure too).
    if ((_IOC_DIR(request) & _IOC_READ) && size > 0 && !copy_to_user(user_arg, arg.data(), size))
      error = EFAULT;
  }
  if (error) return fail(error);  // any fd not handed over closes with `fds`
  return result;
}

void* RemoteFile::mmap(void* address, size_t length, int prot, int flags, off_t offset) {
  if (kind_ == broker::NodeKind::kMedia) {
    errno = ENODEV;  // a media node has no memory to map
    return MAP_FAILED;
  }
  if (!(flags & MAP_SHARED)) {
    errno = EINVAL;  // V4L2 buffers must be mapped shared
    return MAP_FAILED;
  }
  RequestHeader header;
  header.op = Op::kMmap;
  header.offset = offset;
  header.length = length;
  std::vector<uint8_t> reply;
  std::vector<RealFd> fds;
  const int result = transact(encode(header), -1, &reply, &fds);
  if (result < 0 || fds.empty()) {
    errno = result < 0 ? -result : EIO;
    return MAP_FAILED;
  }
  void* mapped = real().mmap(address, length, prot, flags, fds[0].get(), 0);
  const int saved = errno;
  fds.clear();  // the mapping keeps the memory; the fd is not needed
  if (mapped == MAP_FAILED) {
    unmapped(offset);
    errno = saved;
  }
  return mapped;
}

int RemoteFile::header_only_request(const RequestHeader& header, std::vector<uint8_t>* reply) {
  std::vector<RealFd> fds;
  return transact(encode(header), -1, reply, &fds);  // none expected; any closes with `fds`
}

void RemoteFile::unmapped(off_t offset) {
  RequestHeader header;
  header.op = Op::kMunmap;
  header.offset = offset;
  std::vector<uint8_t> reply;
  header_only_request(header, &reply);
}

short RemoteFile::poll_events(short requested) {
  RequestHeader header;
  header.op = Op::kPoll;
  header.flags = requested;
  std::vector<uint8_t> reply;
  const int result = header_only_request(header, &reply);
  if (result < 0 || reply.size() < sizeof(ReplyHeader)) return POLLERR | POLLHUP;
  ReplyHeader out;
  std::memcpy(&out, reply.data(), sizeof out);
  return static_cast<short>(out.revents);
}

RemoteFile::~RemoteFile() {
  if (!socket_ || shared_with_child_) return;
  // Our end says EOF; the broker releases the file and then shuts the connection, which
  // we wait for (bounded: a broker that is gone or stuck does not hang close(2)).
  const int socket = socket_.get();
  if (::shutdown(socket, SHUT_WR) != 0) return;
  for (int waited_ms = 0; waited_ms < 1000; waited_ms += 10) {
    uint8_t discard[64];
    const ssize_t n = ::recv(socket, discard, sizeof discard, MSG_DONTWAIT);
    if (n == 0 || (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR)) return;
    if (n < 0) wait_readable(socket, 10);
  }
}

BrokerClient& BrokerClient::get() {
  // Never destroyed: interposed calls may arrive from other threads and from atexit
  // handlers while the process exits.
  static BrokerClient* client = [] {
    auto* made = new BrokerClient;
    // After a fork the parent's open files may be shared with the child: their last close
    // here must not end the child's (no EOF handshake for them).
    pthread_atfork(
        nullptr, [] { get().mark_all_shared(); }, nullptr);
    return made;
  }();
  return *client;
}

void BrokerClient::mark_all_shared() {
  std::lock_guard lock(mutex_);
  for (auto& [fd, file] : files_) file->mark_shared();
}

int BrokerClient::open(broker::NodeKind kind, int index, int flags) {
  const char* path = std::getenv("CAMLAB_VCAM_BROKER");
  if (!path || !*path) return fail(ENOENT);
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  if (std::strlen(path) >= sizeof address.sun_path) return fail(ENAMETOOLONG);
  std::strcpy(address.sun_path, path);
  RealFd connection(::socket(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0));
  if (!connection) return -1;
  const int socket = connection.get();
  if (::connect(socket, reinterpret_cast<sockaddr*>(&address), sizeof address) < 0)
    return fail(ENODEV);  // the broker is gone: as if the device were unplugged
  RequestHeader header;
  header.op = Op::kOpen;
  header.offset = index;
  header.length = static_cast<uint64_t>(kind);
  header.flags = flags;
  const std::vector<uint8_t> request = encode(header);
  std::vector<uint8_t> reply;
  std::vector<RealFd> fds;
  int result = broker::send_message(socket, request.data(), request.size(), nullptr, 0);
  if (result == 0) {
    const ssize_t n = broker::receive_message(socket, &reply, &fds, (flags & O_CLOEXEC) != 0);
    ReplyHeader out;
    if (n >= static_cast<ssize_t>(sizeof out)) {
      std::memcpy(&out, reply.data(), sizeof out);
      result = out.result;
    } else {
      result = -ENODEV;
    }
  }
  if (result < 0 || fds.size() != 1) return fail(result < 0 ? -result : EIO);
  const int fd = fds[0].release();  // the application's fd from now on
  std::lock_guard lock(mutex_);
  files_[fd] = std::make_shared<RemoteFile>(std::move(connection), kind, index);
  open_fds_ = static_cast<int>(files_.size());
  return fd;
}

std::shared_ptr<RemoteFile> BrokerClient::find(int fd) const {
  if (open_fds_.load(std::memory_order_relaxed) == 0) return nullptr;
  std::lock_guard lock(mutex_);
  auto it = files_.find(fd);
  return it == files_.end() ? nullptr : it->second;
}

void BrokerClient::forget(int fd) {
  std::shared_ptr<RemoteFile> last;  // closes the connection outside the lock
  std::lock_guard lock(mutex_);
  auto it = files_.find(fd);
  if (it == files_.end()) return;
  last = std::move(it->second);
  files_.erase(it);
  open_fds_ = static_cast<int>(files_.size());
}

void BrokerClient::alias(int new_fd, std::shared_ptr<RemoteFile> file) {
  std::lock_guard lock(mutex_);
  files_[new_fd] = std::move(file);
  open_fds_ = static_cast<int>(files_.size());
}

void* BrokerClient::mmap(const std::shared_ptr<RemoteFile>& file, void* address, size_t length,
                         int prot, int flags, off_t offset) {
  void* mapped = file->mmap(address, length, prot, flags, offset);
  if (mapped == MAP_FAILED) return mapped;
  std::lock_guard lock(mutex_);
  mappings_[mapped] = {file, offset};
  mappings_count_ = static_cast<int>(mappings_.size());
  return mapped;
}

bool BrokerClient::owns_mapping(void* address) const {
  if (mappings_count_.load(std::memory_order_relaxed) == 0) return false;
  std::lock_guard lock(mutex_);
  return mappings_.count(address) != 0;
}

int BrokerClient::munmap(void* address, size_t length) {
  Mapping mapping;
  {
    std::lock_guard lock(mutex_);
    auto it = mappings_.find(address);
    if (it != mappings_.end()) {
      mapping = it->second;
      mappings_.erase(it);
      mappings_count_ = static_cast<int>(mappings_.size());
    }
  }
  const int result = real().munmap(address, length);
  // The file may be closed already: its connection then released the mapping count.
  if (auto file = mapping.file.lock()) file->unmapped(mapping.offset);
  return result;
}

int BrokerClient::poll(pollfd* fds, nfds_t count, const timespec* timeout, const sigset_t* mask) {
  using Clock = std::chrono::steady_clock;
  std::vector<std::shared_ptr<RemoteFile>> remote(count);
  bool any_remote = false, needs_slices = false;
  for (nfds_t i = 0; i < count; ++i) {
    if (fds[i].fd >= 0) remote[i] = find(fds[i].fd);
    any_remote |= remote[i] != nullptr;
    // Only "buffer done or error" has a readiness signal (the eventfd); anything else
    // asked of a device (events: POLLPRI) is polled for in short slices.
    needs_slices |= remote[i] && (fds[i].events & ~(POLLIN | POLLRDNORM));
  }
  if (!any_remote) return real().ppoll(fds, count, timeout, mask);
  const bool forever = timeout == nullptr;
  const auto deadline = forever ? Clock::time_point::max()
                                : Clock::now() + std::chrono::seconds(timeout->tv_sec) +
                                      std::chrono::nanoseconds(timeout->tv_nsec);
  std::vector<pollfd> wait_set(fds, fds + count);
  for (;;) {
    // The exact state: the device's own answer for device fds, a zero-timeout poll for
    // the rest.
    for (nfds_t i = 0; i < count; ++i) wait_set[i] = {remote[i] ? -1 : fds[i].fd, fds[i].events, 0};
    const timespec zero{0, 0};
    if (real().ppoll(wait_set.data(), count, &zero, nullptr) < 0) return -1;
    int ready = 0;
    for (nfds_t i = 0; i < count; ++i) {
      fds[i].revents = remote[i] ? remote[i]->poll_events(fds[i].events) : wait_set[i].revents;
      ready += fds[i].revents != 0;
    }
    const auto now = Clock::now();
    if (ready > 0 || (!forever && now >= deadline)) return ready;
    // Sleep until something may have changed: a device fd turns readable with a done
    // buffer or an error; events (POLLPRI) have no readiness signal, so poll for them in
    // short slices.
    for (nfds_t i = 0; i < count; ++i) {
      const bool wants_buffers = fds[i].events & (POLLIN | POLLRDNORM);
      wait_set[i] = {remote[i] && !wants_buffers ? -1 : fds[i].fd,
                     static_cast<short>(remote[i] ? POLLIN : fds[i].events), 0};
    }
    auto slice = forever ? std::chrono::nanoseconds(std::chrono::hours(1)) : deadline - now;
    if (needs_slices)
      slice = std::min<std::chrono::nanoseconds>(slice, std::chrono::milliseconds(5));
    const auto slice_ns = std::chrono::duration_cast<std::chrono::nanoseconds>(slice).count();
    const timespec wait{static_cast<time_t>(slice_ns / 1000000000),
                        static_cast<long>(slice_ns % 1000000000)};
    if (real().ppoll(wait_set.data(), count, &wait, mask) < 0) return -1;  // EINTR included
  }
}

}  // namespace camlab::mock::preload
