// The vcam broker's wire protocol (mock_device/broker/broker_protocol.h): any process in
// `camlab vcam run` sends the broker ioctl argument structs, and the broker reads the
// arrays they point to from the sizes in them. The harness gives the protocol's readers a
// request number (the first byte picks one) and an argument struct of the fuzzer's bytes,
// then sends the whole input as one message over a SOCK_SEQPACKET pair and receives it.
// The broker's dispatch itself (vcam_broker.cpp) needs a whole virtual device and is not
// linked here.
#include <linux/media.h>
#include <linux/videodev2.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "mock_device/broker/broker_protocol.h"
#include "tests/fuzz/fuzz_check.h"

namespace {

namespace broker = camlab::mock::broker;

constexpr std::array<unsigned long, 10> kRequests = {
    VIDIOC_G_EXT_CTRLS,   VIDIOC_S_EXT_CTRLS, VIDIOC_TRY_EXT_CTRLS, VIDIOC_QBUF,
    VIDIOC_PREPARE_BUF,   VIDIOC_EXPBUF,      VIDIOC_QUERYCAP,      MEDIA_IOC_G_TOPOLOGY,
    MEDIA_IOC_ENUM_LINKS, VIDIOC_DQBUF};

struct SocketPair {
  int fds[2] = {-1, -1};
  SocketPair() {
    if (::socketpair(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0, fds) != 0) std::abort();
  }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using camlab::fuzz::check;
  if (size < 1) return 0;
  const unsigned long request = kRequests[data[0] % kRequests.size()];
  // The broker copies at most kMaxArgBytes of argument into an aligned buffer.
  alignas(16) std::array<uint8_t, broker::kMaxArgBytes> arg{};
  std::memcpy(arg.data(), data + 1, std::min(size - 1, arg.size()));

  std::vector<broker::UserBuffer> buffers;
  const int result = broker::user_buffers_of(request, arg.data(), &buffers);
  check(result == 0 || result == -EINVAL, "user_buffers_of: an unexpected error");
  check(buffers.size() <= broker::kMaxUserBuffers, "more user buffers than the protocol allows");
  for (const auto& b : buffers)
    check(b.pointer_offset + sizeof(void*) <= broker::kMaxArgBytes, "a pointer outside the arg");
  const uint32_t fd_in = broker::fd_in_field(request, arg.data());
  check(fd_in == broker::kNoField || fd_in + sizeof(int) <= broker::kMaxArgBytes,
        "an fd field outside the arg");
  (void)broker::fd_out_field(request);

  // The message layer: a message of any bytes arrives whole, with no fds.
  static const SocketPair pair;
  if (size <= 65536) {
    check(broker::send_message(pair.fds[0], data, size, nullptr, 0) == 0, "send_message failed");
    std::vector<uint8_t> received;
    std::vector<int> fds;
    const ssize_t n = broker::receive_message(pair.fds[1], &received, &fds);
    check(n == static_cast<ssize_t>(size), "receive_message: wrong size");
    check(received.size() == size && std::memcmp(received.data(), data, size) == 0,
          "receive_message: wrong bytes");
    check(fds.empty(), "receive_message: fds from nowhere");
  }
  return 0;
}
