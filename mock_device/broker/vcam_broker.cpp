#include "mock_device/broker/vcam_broker.h"

#include <fcntl.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <map>

#include "mock_device/broker/broker_protocol.h"

namespace camlab::mock {

namespace {

using broker::Op;
using broker::ReplyHeader;
using broker::RequestHeader;
using broker::UserBuffer;

int reply(int socket, const ReplyHeader& header, const std::vector<uint8_t>& body = {},
          int fd = -1) {
  std::vector<uint8_t> message(sizeof header + body.size());
  std::memcpy(message.data(), &header, sizeof header);
  if (!body.empty()) std::memcpy(message.data() + sizeof header, body.data(), body.size());
  return broker::send_message(socket, message.data(), message.size(), &fd, fd >= 0 ? 1 : 0);
}

int reply_result(int socket, int result) {
  ReplyHeader header;
  header.result = result;
  return reply(socket, header);
}

// One open file of one node (a video node, or a media node when `media` is set), as
// seen by the connection that opened it.
class OpenFile {
 public:
  OpenFile(std::shared_ptr<VirtualV4l2Device> device, std::shared_ptr<VirtualMediaDevice> media,
           int file)
      : device_(std::move(device)), media_(std::move(media)), file_(file) {}
  ~OpenFile() {
    if (media_) {
      media_->close_file(file_);
      return;
    }
    // A client that dies with buffers mapped leaves the device's mapping counts as if it
    // had unmapped them: its address space is gone.
    for (const auto& [offset, count] : mappings_) device_->note_mapping(offset, -count);
    device_->close_file(file_);
  }

  // Answers one request; returns false when the connection must end.
  bool handle(int socket, const std::vector<uint8_t>& message, std::vector<UniqueFd>& fds) {
    RequestHeader header;
    std::memcpy(&header, message.data(), sizeof header);
    if (media_) return handle_media(socket, header, message);
    switch (header.op) {
      case Op::kIoctl:
        return ioctl(socket, header, message, fds) == 0;
      case Op::kMmap:
        return mmap(socket, header) == 0;
      case Op::kMunmap: {
        auto it = mappings_.find(header.offset);
        if (it != mappings_.end() && it->second > 0) {
          device_->note_mapping(header.offset, -1);
          if (--it->second == 0) mappings_.erase(it);
        }
        return reply_result(socket, 0) == 0;
      }
      case Op::kPoll: {
        ReplyHeader out;
        out.revents = device_->poll_events(file_, static_cast<short>(header.flags));
        return reply(socket, out) == 0;
      }
      default:
        return reply_result(socket, -EINVAL) == 0;
    }
  }

 private:
  // A media node: ioctls only. It has no mmap (ENODEV) and, like the kernel's media
  // devnode without a poll handler, is always "ready".
  bool handle_media(int socket, const RequestHeader& header, const std::vector<uint8_t>& message) {
    switch (header.op) {
      case Op::kIoctl:
        return media_ioctl(socket, header, message) == 0;
      case Op::kMmap:
        return reply_result(socket, -ENODEV) == 0;
      case Op::kMunmap:
        return reply_result(socket, 0) == 0;
      case Op::kPoll: {
        ReplyHeader out;
        out.revents = header.flags & (POLLIN | POLLOUT | POLLRDNORM | POLLWRNORM);
        return reply(socket, out) == 0;
      }
      default:
        return reply_result(socket, -EINVAL) == 0;
    }
  }

  // The media ioctls' arrays (G_TOPOLOGY's, ENUM_LINKS') are sized by the device, not
  // sent by the client: they go back as copy-out regions at the client's addresses.
  int media_ioctl(int socket, const RequestHeader& header, const std::vector<uint8_t>& message) {
    const unsigned long request = header.ioctl_request;
    if (!VirtualMediaDevice::is_supported_ioctl(request)) return reply_result(socket, -ENOTTY);
    if (header.arg_unreadable) return reply_result(socket, -EFAULT);
    const size_t arg_size = header.arg_size;
    if (arg_size != _IOC_SIZE(request) || arg_size > broker::kMaxArgBytes ||
        header.user_buffer_count != 0 || message.size() < sizeof header + arg_size)
      return reply_result(socket, -EINVAL);
    std::vector<uint64_t> arg((arg_size + 7) / 8 + 1);
    std::memcpy(arg.data(), message.data() + sizeof header, arg_size);
    std::vector<uint8_t> regions;
    uint32_t region_count = 0;
    auto copy_in = [](uint64_t, void*, size_t) {
      return -EFAULT;
    };  // no media ioctl reads an array
    auto copy_out = [&](uint64_t address, const void* local, size_t bytes) {
      if (bytes == 0) return 0;
      if (region_count >= broker::kMaxCopyOuts ||
          regions.size() + bytes > broker::kMaxUserBufferBytes)
        return -EFAULT;
      broker::CopyOut region;
      region.address = address;
      region.size_bytes = static_cast<uint32_t>(bytes);
      const auto* head = reinterpret_cast<const uint8_t*>(&region);
      regions.insert(regions.end(), head, head + sizeof region);
      regions.insert(regions.end(), static_cast<const uint8_t*>(local),
                     static_cast<const uint8_t*>(local) + bytes);
      ++region_count;
      return 0;
    };
    const int result = media_->ioctl_marshalled(file_, request, arg.data(), copy_in, copy_out);
    ReplyHeader out;
    out.result = result;
    out.copy_out_count = region_count;
    std::vector<uint8_t> body;
    // The struct goes back only on success (mc-device.c's arg_to_user); the arrays also
    // on ENOSPC.
    if (result == 0) {
      out.arg_size = static_cast<uint32_t>(arg_size);
      body.assign(reinterpret_cast<const uint8_t*>(arg.data()),
                  reinterpret_cast<const uint8_t*>(arg.data()) + arg_size);
    }
    body.insert(body.end(), regions.begin(), regions.end());
    return reply(socket, out, body);
  }

  int ioctl(int socket, const RequestHeader& header, const std::vector<uint8_t>& message,
            std::vector<UniqueFd>& fds) {
    const unsigned long request = header.ioctl_request;
    // Unknown ioctls are ENOTTY before the argument is looked at, as in the kernel.
    if (!VirtualV4l2Device::is_supported_ioctl(request)) return reply_result(socket, -ENOTTY);
    if (header.arg_unreadable) return reply_result(socket, -EFAULT);
    const size_t arg_size = header.arg_size;
    if (arg_size != _IOC_SIZE(request) || arg_size > broker::kMaxArgBytes ||
        header.user_buffer_count > broker::kMaxUserBuffers)
      return reply_result(socket, -EINVAL);
    size_t at = sizeof header;
    if (message.size() < at + arg_size + header.user_buffer_count * sizeof(UserBuffer))
      return reply_result(socket, -EINVAL);
    // 8-byte aligned copies: the device reads the struct and the arrays in place.
    std::vector<uint64_t> arg((arg_size + 7) / 8 + 1);
    std::memcpy(arg.data(), message.data() + at, arg_size);
    at += arg_size;
    std::vector<UserBuffer> specs(header.user_buffer_count);
    if (!specs.empty())
      std::memcpy(specs.data(), message.data() + at, specs.size() * sizeof(UserBuffer));
    at += specs.size() * sizeof(UserBuffer);
    // The arrays must be the ones this request implies, so a client cannot make the
    // device write through a pointer of its choosing.
    std::vector<UserBuffer> expected;
    if (int error = broker::user_buffers_of(request, arg.data(), &expected); error < 0)
      return reply_result(socket, error);
    if (expected.size() != specs.size()) return reply_result(socket, -EINVAL);
    std::vector<std::vector<uint64_t>> buffers(specs.size());
    std::vector<void*> client_pointers(specs.size());
    for (size_t i = 0; i < specs.size(); ++i) {
      if (specs[i].pointer_offset != expected[i].pointer_offset ||
          specs[i].size_bytes != expected[i].size_bytes ||
          message.size() < at + specs[i].size_bytes)
        return reply_result(socket, -EINVAL);
      buffers[i].resize((specs[i].size_bytes + 7) / 8 + 1);
      std::memcpy(buffers[i].data(), message.data() + at, specs[i].size_bytes);
      at += specs[i].size_bytes;
      auto* field = reinterpret_cast<uint8_t*>(arg.data()) + specs[i].pointer_offset;
      std::memcpy(&client_pointers[i], field, sizeof(void*));
      void* local = buffers[i].data();
      std::memcpy(field, &local, sizeof(void*));
    }
    // A DMABUF being queued: the fd arrived with the message. The device maps ours but
    // m.fd stays the client's number, which QBUF, DQBUF and QUERYBUF report back (vb2
    // keeps the number the caller gave). The caller closes the received fd.
    int dmabuf_fd = -1;
    if (broker::fd_in_field(request, arg.data()) != broker::kNoField) {
      if (fds.size() != 1) return reply_result(socket, -EBADF);
      dmabuf_fd = fds[0].get();
    }

    const int result = device_->ioctl(file_, request, arg.data(), dmabuf_fd);

    for (size_t i = 0; i < specs.size(); ++i)
      std::memcpy(reinterpret_cast<uint8_t*>(arg.data()) + specs[i].pointer_offset,
                  &client_pointers[i], sizeof(void*));
    int fd_out = -1;  // an fd the device made for the client (EXPBUF): ours until sent
    ReplyHeader out;
    out.result = result;
    out.arg_size = static_cast<uint32_t>(arg_size);
    out.user_buffer_count = static_cast<uint32_t>(specs.size());
    if (result >= 0 && broker::fd_out_field(request) != broker::kNoField) {
      out.fd_field_offset = broker::fd_out_field(request);
      std::memcpy(&fd_out, reinterpret_cast<uint8_t*>(arg.data()) + out.fd_field_offset,
                  sizeof(int));
    }
    const UniqueFd exported(fd_out);  // the client gets its own copy; ours closes here
    // A dequeued USERPTR buffer: its frame's memfd (the device's, borrowed) goes along, and
    // the client copies the frame to the application's pointer (broker_client.cpp).
    int userptr_fd = -1;
    if (const auto* b = reinterpret_cast<const v4l2_buffer*>(arg.data());
        result == 0 && request == VIDIOC_DQBUF && b->memory == V4L2_MEMORY_USERPTR) {
      VirtualV4l2Device::BufferMemory source{};
      if (device_->userptr_source(b->index, &source) == 0) userptr_fd = source.memfd;
    }
    std::vector<uint8_t> body(arg_size);
    std::memcpy(body.data(), arg.data(), arg_size);
    for (size_t i = 0; i < specs.size(); ++i) {
      const auto* bytes = reinterpret_cast<const uint8_t*>(buffers[i].data());
      body.insert(body.end(), bytes, bytes + specs[i].size_bytes);
    }
    return reply(socket, out, body, fd_out >= 0 ? fd_out : userptr_fd);
  }

  int mmap(int socket, const RequestHeader& header) {
    VirtualV4l2Device::BufferMemory memory{};
    const int error = device_->buffer_for_mmap(header.offset, header.length, &memory);
    if (error < 0) return reply_result(socket, error);
    device_->note_mapping(header.offset, +1);
    ++mappings_[header.offset];
    ReplyHeader out;
    return reply(socket, out, {}, memory.memfd);
  }

  std::shared_ptr<VirtualV4l2Device> device_;
  std::shared_ptr<VirtualMediaDevice> media_;
  int file_;
  std::map<off_t, int> mappings_;  // mmap offset -> mappings this client holds
};

int inject(VirtualV4l2Device& device, broker::Fault fault, int count) {
  if (count < 0 || count > 1000000) return -EINVAL;
  switch (fault) {
    case broker::Fault::kUnplug:
      device.unplug();
      return 0;
    case broker::Fault::kDequeueEio:
      device.fail_next_dequeues(count);
      return 0;
    case broker::Fault::kDropFrames:
      device.drop_next_frames(count);
      return 0;
    case broker::Fault::kStall:
      device.stall(true);
      return 0;
    case broker::Fault::kResume:
      device.stall(false);
      return 0;
    case broker::Fault::kReplug:
      device.replug();
      return 0;
  }
  return -EINVAL;
}

}  // namespace

Result<std::unique_ptr<VcamBroker>> VcamBroker::start(
    std::vector<std::shared_ptr<VirtualV4l2Device>> devices, const std::string& socket_path) {
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  if (socket_path.size() >= sizeof address.sun_path)
    return make_error("invalid_argument", "broker socket path too long (max " +
                                              std::to_string(sizeof address.sun_path - 1) +
                                              " bytes): " + socket_path);
  std::memcpy(address.sun_path, socket_path.c_str(), socket_path.size() + 1);
  UniqueFd fd(::socket(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0));
  if (!fd) return make_error("io_error", std::string("broker socket: ") + std::strerror(errno));
  if (::bind(fd.get(), reinterpret_cast<sockaddr*>(&address), sizeof address) < 0 ||
      ::listen(fd.get(), 64) < 0)
    return make_error("io_error",
                      "broker cannot listen on " + socket_path + ": " + std::strerror(errno));
  std::unique_ptr<VcamBroker> broker(
      new VcamBroker(std::move(devices), socket_path, std::move(fd)));
  for (const auto& device : broker->devices_) {
    auto media = make_media_device_for(*device);
    if (!media) continue;
    const std::string name = "camlab-media" + std::to_string(device->index());
    UniqueFd memfd(::memfd_create(name.c_str(), MFD_CLOEXEC));
    if (!memfd) return make_error("io_error", std::string("broker memfd: ") + std::strerror(errno));
    broker->media_.push_back({std::move(media), std::move(memfd)});
  }
  broker->acceptor_ = std::thread([b = broker.get()] { b->accept_loop(); });
  return broker;
}

VcamBroker::VcamBroker(std::vector<std::shared_ptr<VirtualV4l2Device>> devices,
                       std::string socket_path, UniqueFd listen_fd)
    : devices_(std::move(devices)),
      socket_path_(std::move(socket_path)),
      listen_fd_(std::move(listen_fd)) {}

std::shared_ptr<VirtualMediaDevice> VcamBroker::media_device(int index) const {
  for (const auto& node : media_)
    if (node.device->index() == index) return node.device;
  return nullptr;
}

VcamBroker::~VcamBroker() {
  stopping_ = true;
  ::shutdown(listen_fd_.get(), SHUT_RDWR);  // wakes accept()
  if (acceptor_.joinable()) acceptor_.join();
  listen_fd_.reset();
  ::unlink(socket_path_.c_str());
  std::lock_guard lock(mutex_);
  // Sockets stay open until their thread is joined, so these fds are still ours.
  for (auto& c : connections_) ::shutdown(c.socket.get(), SHUT_RDWR);  // wakes each recv()
  for (auto& c : connections_) c.thread.join();
  connections_.clear();  // closes the sockets
  // The media nodes' memfds close with media_.
}

size_t VcamBroker::open_file_count() const {
  std::lock_guard lock(mutex_);
  size_t count = 0;
  for (const auto& c : connections_) count += !c.finished;
  return count;
}

void VcamBroker::reap_finished() {
  for (auto it = connections_.begin(); it != connections_.end();) {
    if (!it->finished) {
      ++it;
      continue;
    }
    it->thread.join();
    it = connections_.erase(it);  // closes its socket
  }
}

void VcamBroker::accept_loop() {
  while (!stopping_) {
    UniqueFd socket(::accept4(listen_fd_.get(), nullptr, nullptr, SOCK_CLOEXEC));
    if (!socket) {
      if (errno == EINTR || errno == ECONNABORTED) continue;
      return;  // shut down
    }
    std::lock_guard lock(mutex_);
    reap_finished();
    if (stopping_) return;
    Connection& c = connections_.emplace_back();
    c.socket = std::move(socket);
    c.thread = std::thread([this, &c] { serve(&c); });
  }
}

void VcamBroker::serve(Connection* connection) {
  const int socket = connection->socket.get();
  std::vector<uint8_t> message;
  std::vector<UniqueFd> fds;
  std::unique_ptr<OpenFile> open_file;
  // The readiness eventfd of a video file: the device signals it; the client has a copy.
  UniqueFd readiness_fd;
  ssize_t n = broker::receive_message(socket, &message, &fds);
  RequestHeader header;
  if (n >= static_cast<ssize_t>(sizeof header)) {
    std::memcpy(&header, message.data(), sizeof header);
    std::shared_ptr<VirtualV4l2Device> device;
    for (const auto& d : devices_)
      if (d->index() == header.offset) device = d;
    const MediaNode* media = nullptr;
    for (const auto& node : media_)
      if (node.device->index() == header.offset) media = &node;
    const auto kind = static_cast<broker::NodeKind>(header.length);
    if (header.op == Op::kFault) {
      int result = device ? inject(*device, static_cast<broker::Fault>(header.flags),
                                   static_cast<int>(header.length))
                          : -ENODEV;
      if (result == 0 && media &&
          static_cast<broker::Fault>(header.flags) == broker::Fault::kUnplug)
        media->device->unplug();
      if (result == 0 && media &&
          static_cast<broker::Fault>(header.flags) == broker::Fault::kReplug)
        media->device->replug();
      reply_result(socket, result);
    } else if (header.op == Op::kOpen && kind == broker::NodeKind::kMedia && media) {
      // Each open is its own open file description of the node's memfd (one inode per
      // node, as the kernel's device inode): lockf() by one process then excludes
      // another, and O_NONBLOCK stays per open.
      const int file = media->device->open_file(header.flags & O_NONBLOCK);
      const std::string self = "/proc/self/fd/" + std::to_string(media->memfd.get());
      // Sent to the client, which has its own copy then; ours closes at the end of scope.
      const UniqueFd fd(
          file < 0 ? -1 : ::open(self.c_str(), O_RDWR | O_CLOEXEC | (header.flags & O_NONBLOCK)));
      if (file < 0 || !fd) {
        if (file >= 0) media->device->close_file(file);
        reply_result(socket, file < 0 ? file : -errno);
      } else {
        open_file = std::make_unique<OpenFile>(nullptr, media->device, file);
        ReplyHeader out;
        if (reply(socket, out, {}, fd.get()) != 0) open_file.reset();
      }
    } else if (header.op != Op::kOpen || kind != broker::NodeKind::kVideo || !device) {
      reply_result(socket, -ENODEV);
    } else {
      // The broker's side of every file is non-blocking; the client emulates blocking
      // DQBUF on the readiness fd, so no request ever waits here.
      const int file = device->open_file(true);
      readiness_fd.reset(
          file < 0 ? -1
                   : ::eventfd(0, EFD_CLOEXEC | ((header.flags & O_NONBLOCK) ? EFD_NONBLOCK : 0)));
      if (file < 0 || !readiness_fd) {
        if (file >= 0) device->close_file(file);
        reply_result(socket, file < 0 ? file : -errno);
      } else {
        device->attach_eventfd(file, readiness_fd.get());
        open_file = std::make_unique<OpenFile>(device, nullptr, file);
        ReplyHeader out;
        if (reply(socket, out, {}, readiness_fd.get()) != 0) open_file.reset();
      }
    }
  }
  fds.clear();
  while (open_file) {
    n = broker::receive_message(socket, &message, &fds);
    if (n < static_cast<ssize_t>(sizeof(RequestHeader)))
      break;  // the client closed the file (or died)
    const bool keep = open_file->handle(socket, message, fds);
    fds.clear();  // the device keeps no fd it was sent (it maps a DMABUF at QBUF)
    if (!keep) break;
  }
  open_file.reset();              // detaches the readiness fd before it closes
  ::shutdown(socket, SHUT_RDWR);  // the client sees EOF now; the fd is closed when reaped
  connection->finished = true;
}

}  // namespace camlab::mock
