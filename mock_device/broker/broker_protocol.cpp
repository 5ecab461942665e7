#include "mock_device/broker/broker_protocol.h"

#include "base/unique_fd.h"

#include <linux/videodev2.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace camlab::mock::broker {

int user_buffers_of(unsigned long request, const void* arg, std::vector<UserBuffer>* out) {
  out->clear();
  if (request == VIDIOC_G_EXT_CTRLS || request == VIDIOC_S_EXT_CTRLS ||
      request == VIDIOC_TRY_EXT_CTRLS) {
    const auto* controls = static_cast<const v4l2_ext_controls*>(arg);
    // The kernel's limit (V4L2_CID_MAX_CTRLS) on how many controls one call may carry.
    if (controls->count > 1024) return -EINVAL;
    if (controls->count > 0)
      out->push_back({static_cast<uint32_t>(offsetof(v4l2_ext_controls, controls)),
                      static_cast<uint32_t>(controls->count * sizeof(v4l2_ext_control))});
  }
  return 0;
}

uint32_t fd_in_field(unsigned long request, const void* arg) {
  if (request != VIDIOC_QBUF && request != VIDIOC_PREPARE_BUF) return kNoField;
  const auto* buffer = static_cast<const v4l2_buffer*>(arg);
  if (buffer->memory != V4L2_MEMORY_DMABUF || V4L2_TYPE_IS_MULTIPLANAR(buffer->type))
    return kNoField;
  return static_cast<uint32_t>(offsetof(v4l2_buffer, m.fd));
}

uint32_t fd_out_field(unsigned long request) {
  return request == VIDIOC_EXPBUF ? static_cast<uint32_t>(offsetof(v4l2_exportbuffer, fd))
                                  : kNoField;
}

int send_message(int socket, const void* data, size_t size, const int* fds, int fd_count) {
  iovec io{const_cast<void*>(data), size};
  msghdr message{};
  message.msg_iov = &io;
  message.msg_iovlen = 1;
  alignas(cmsghdr) char control[CMSG_SPACE(4 * sizeof(int))] = {};
  if (fd_count > 0) {
    if (fd_count > 4) return -EINVAL;
    message.msg_control = control;
    message.msg_controllen = CMSG_SPACE(fd_count * sizeof(int));
    cmsghdr* header = CMSG_FIRSTHDR(&message);
    header->cmsg_level = SOL_SOCKET;
    header->cmsg_type = SCM_RIGHTS;
    header->cmsg_len = CMSG_LEN(fd_count * sizeof(int));
    std::memcpy(CMSG_DATA(header), fds, fd_count * sizeof(int));
  }
  for (;;) {
    const ssize_t sent = ::sendmsg(socket, &message, MSG_NOSIGNAL);
    if (sent >= 0) return sent == static_cast<ssize_t>(size) ? 0 : -EMSGSIZE;
    if (errno != EINTR) return -errno;
  }
}

ssize_t receive_message(int socket, std::vector<uint8_t>* data, std::vector<int>* fds,
                        bool cloexec) {
  // SOCK_SEQPACKET keeps message boundaries: peek at the size first so no message is
  // ever truncated.
  ssize_t size;
  for (;;) {
    size = ::recv(socket, nullptr, 0, MSG_PEEK | MSG_TRUNC);
    if (size >= 0) break;
    if (errno != EINTR) return -errno;
  }
  // Neither side sends empty messages, so an empty read is the peer's shutdown.
  if (size == 0) return 0;
  data->resize(static_cast<size_t>(size));
  iovec io{data->data(), data->size()};
  msghdr message{};
  message.msg_iov = &io;
  message.msg_iovlen = 1;
  alignas(cmsghdr) char control[CMSG_SPACE(4 * sizeof(int))];
  message.msg_control = control;
  message.msg_controllen = sizeof control;
  ssize_t received;
  for (;;) {
    received = ::recvmsg(socket, &message, cloexec ? MSG_CMSG_CLOEXEC : 0);
    if (received >= 0) break;
    if (errno != EINTR) return -errno;
  }
  for (cmsghdr* header = CMSG_FIRSTHDR(&message); header; header = CMSG_NXTHDR(&message, header)) {
    if (header->cmsg_level != SOL_SOCKET || header->cmsg_type != SCM_RIGHTS) continue;
    const size_t count = (header->cmsg_len - CMSG_LEN(0)) / sizeof(int);
    for (size_t i = 0; i < count; ++i) {
      int fd;
      std::memcpy(&fd, CMSG_DATA(header) + i * sizeof(int), sizeof fd);
      fds->push_back(fd);
    }
  }
  data->resize(static_cast<size_t>(received));
  return received;
}

int inject_fault(const char* socket_path, int index, Fault fault, int count) {
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  if (!socket_path || std::strlen(socket_path) >= sizeof address.sun_path) return -EINVAL;
  std::strcpy(address.sun_path, socket_path);
  const UniqueFd owned_socket(::socket(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0));
  if (!owned_socket) return -errno;
  const int socket = owned_socket.get();
  int result = 0;
  if (::connect(socket, reinterpret_cast<sockaddr*>(&address), sizeof address) < 0) {
    result = -errno;
  } else {
    RequestHeader header;
    header.op = Op::kFault;
    header.offset = index;
    header.flags = static_cast<int32_t>(fault);
    header.length = static_cast<uint64_t>(count);
    result = send_message(socket, &header, sizeof header, nullptr, 0);
    std::vector<uint8_t> reply;
    std::vector<UniqueFd> fds;  // none expected; closed with their owners
    if (result == 0) {
      const ssize_t n = receive_message(socket, &reply, &fds);
      ReplyHeader out;
      if (n >= static_cast<ssize_t>(sizeof out)) {
        std::memcpy(&out, reply.data(), sizeof out);
        result = out.result;
      } else {
        result = n < 0 ? static_cast<int>(n) : -EIO;
      }
    }
  }
  return result;
}

}  // namespace camlab::mock::broker
