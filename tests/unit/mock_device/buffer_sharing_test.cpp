// Buffer export and import on the virtual V4L2 device, in process: VIDIOC_EXPBUF hands
// out fds of the MMAP buffers' memory, V4L2_MEMORY_DMABUF renders into buffers the
// client brings, and libcamera's sequence (export MMAP buffers, free them, import the
// exported fds as DMABUF) delivers the same frames as plain MMAP streaming.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <linux/videodev2.h>
#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <vector>

#include "mock_device/v4l2/virtual_v4l2_io.h"
#include "test_specs.h"

namespace camlab::mock {
namespace {

constexpr uint32_t kWidth = 64, kHeight = 48, kFrameBytes = kWidth * kHeight;  // GREY

class BufferSharing : public ::testing::Test {
 protected:
  void SetUp() override {
    nlohmann::json camera = testing::pinhole_camera_json(kWidth, kHeight);
    camera["sensor"]["read_noise_e"] = 0.0;
    camera["sensor"]["shot_noise"] = false;  // every frame is the same image
    camera["timing"] = {{"frame_interval_us", 10000}, {"control_latency_frames", 0}};
    camera["controls"]["exposure_time_absolute"] = {{"min", 1}, {"max", 100}, {"default", 50}};
    auto spec = parse_camera_spec(camera);
    auto scene = parse_scene_spec(testing::uniform_scene_json(1.0, 0.5));
    ASSERT_TRUE(spec.ok()) << spec.error().message;
    ASSERT_TRUE(scene.ok()) << scene.error().message;
    VirtualDeviceOptions options;
    options.realtime = false;
    auto created = VirtualV4l2Device::create(std::move(*spec), std::move(*scene), options);
    ASSERT_TRUE(created.ok());
    device = std::move(*created);
    io = std::make_unique<VirtualV4l2Io>(std::vector{device});
    fd = io->open("/dev/video0", O_RDWR);
    ASSERT_GE(fd, 0);
    v4l2_format format{};
    format.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    format.fmt.pix = {kWidth, kHeight, V4L2_PIX_FMT_GREY};
    ASSERT_EQ(io->ioctl(fd, VIDIOC_S_FMT, &format), 0);
    ASSERT_EQ(format.fmt.pix.sizeimage, kFrameBytes);
  }
  void TearDown() override {
    if (fd >= 0) io->close(fd);
  }

  int reqbufs(uint32_t count, v4l2_memory memory) {
    v4l2_requestbuffers request{};
    request.count = count;
    request.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    request.memory = memory;
    const int result = io->ioctl(fd, VIDIOC_REQBUFS, &request);
    last_capabilities = request.capabilities;
    return result == 0 ? static_cast<int>(request.count) : -errno;
  }
  int export_buffer(uint32_t index, uint32_t flags, int* out) {
    v4l2_exportbuffer e{};
    e.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    e.index = index;
    e.flags = flags;
    if (io->ioctl(fd, VIDIOC_EXPBUF, &e) != 0) return -errno;
    *out = e.fd;
    return 0;
  }
  int queue_dmabuf(uint32_t index, int buffer_fd, uint32_t length, v4l2_buffer* out = nullptr) {
    v4l2_buffer b{};
    b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    b.memory = V4L2_MEMORY_DMABUF;
    b.index = index;
    b.m.fd = buffer_fd;
    b.length = length;
    if (io->ioctl(fd, VIDIOC_QBUF, &b) != 0) return -errno;
    if (out) *out = b;
    return 0;
  }
  v4l2_buffer dequeue(v4l2_memory memory) {
    v4l2_buffer b{};
    b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    b.memory = memory;
    EXPECT_EQ(io->ioctl(fd, VIDIOC_DQBUF, &b), 0) << std::strerror(errno);
    return b;
  }
  int stream(bool on) {
    int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    return io->ioctl(fd, on ? VIDIOC_STREAMON : VIDIOC_STREAMOFF, &type);
  }
  static int make_memfd(size_t bytes) {
    const int memfd = memfd_create("test-dmabuf", MFD_CLOEXEC);
    if (memfd >= 0 && ftruncate(memfd, static_cast<off_t>(bytes)) != 0) {
      close(memfd);
      return -1;
    }
    return memfd;
  }
  static std::vector<uint8_t> read_fd(int buffer_fd, size_t bytes) {
    void* address = mmap(nullptr, bytes, PROT_READ, MAP_SHARED, buffer_fd, 0);
    if (address == MAP_FAILED) return {};
    std::vector<uint8_t> data(static_cast<uint8_t*>(address),
                              static_cast<uint8_t*>(address) + bytes);
    munmap(address, bytes);
    return data;
  }
  // A frame through plain MMAP streaming: what every other path must deliver.
  std::vector<uint8_t> mmap_frame() {
    EXPECT_EQ(reqbufs(2, V4L2_MEMORY_MMAP), 2);
    v4l2_buffer b{};
    b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    b.memory = V4L2_MEMORY_MMAP;
    EXPECT_EQ(io->ioctl(fd, VIDIOC_QUERYBUF, &b), 0);
    void* address = io->mmap(b.length, PROT_READ, MAP_SHARED, fd, b.m.offset);
    EXPECT_NE(address, MAP_FAILED);
    EXPECT_EQ(io->ioctl(fd, VIDIOC_QBUF, &b), 0);
    EXPECT_EQ(stream(true), 0);
    dequeue(V4L2_MEMORY_MMAP);
    std::vector<uint8_t> data(static_cast<uint8_t*>(address),
                              static_cast<uint8_t*>(address) + kFrameBytes);
    EXPECT_EQ(stream(false), 0);
    io->munmap(address, b.length);
    EXPECT_EQ(reqbufs(0, V4L2_MEMORY_MMAP), 0);
    return data;
  }

  std::shared_ptr<VirtualV4l2Device> device;
  std::unique_ptr<VirtualV4l2Io> io;
  int fd = -1;
  uint32_t last_capabilities = 0;
};

TEST_F(BufferSharing, ExportedFdSeesTheBufferAndHonoursFlags) {
  ASSERT_EQ(reqbufs(2, V4L2_MEMORY_MMAP), 2);
  EXPECT_EQ(last_capabilities & (V4L2_BUF_CAP_SUPPORTS_MMAP | V4L2_BUF_CAP_SUPPORTS_DMABUF),
            static_cast<uint32_t>(V4L2_BUF_CAP_SUPPORTS_MMAP | V4L2_BUF_CAP_SUPPORTS_DMABUF));
  int exported = -1, read_only = -1;
  ASSERT_EQ(export_buffer(0, O_RDWR | O_CLOEXEC, &exported), 0);
  ASSERT_EQ(export_buffer(0, O_RDONLY, &read_only), 0);
  EXPECT_FALSE(io->owns(exported)) << "an exported buffer is an ordinary fd of the process";
  EXPECT_NE(fcntl(exported, F_GETFD) & FD_CLOEXEC, 0);
  EXPECT_EQ(fcntl(read_only, F_GETFD) & FD_CLOEXEC, 0);
  EXPECT_EQ(fcntl(read_only, F_GETFL) & O_ACCMODE, O_RDONLY);
  EXPECT_EQ(mmap(nullptr, kFrameBytes, PROT_WRITE, MAP_SHARED, read_only, 0), MAP_FAILED);

  // A frame rendered into buffer 0 shows through the exported fd.
  v4l2_buffer b{};
  b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  b.memory = V4L2_MEMORY_MMAP;
  ASSERT_EQ(io->ioctl(fd, VIDIOC_QBUF, &b), 0);
  ASSERT_EQ(stream(true), 0);
  EXPECT_EQ(dequeue(V4L2_MEMORY_MMAP).index, 0u);
  const auto through_export = read_fd(exported, kFrameBytes);
  ASSERT_EQ(stream(false), 0);
  ASSERT_EQ(reqbufs(0, V4L2_MEMORY_MMAP), 0);
  EXPECT_NE(through_export, std::vector<uint8_t>(kFrameBytes, 0));
  EXPECT_EQ(through_export, mmap_frame());
  EXPECT_EQ(read_fd(exported, kFrameBytes), through_export)
      << "the memory outlives the freed buffers";
  close(exported);
  close(read_only);
}

TEST_F(BufferSharing, ExpbufChecksItsArgumentsLikeVb2) {
  int exported = -1;
  v4l2_exportbuffer zero{};
  EXPECT_EQ(io->ioctl(fd, VIDIOC_EXPBUF, &zero), -1);
  EXPECT_EQ(errno, EINVAL) << "supported (not ENOTTY), so v4l2-compliance tests it";
  ASSERT_EQ(reqbufs(2, V4L2_MEMORY_MMAP), 2);
  EXPECT_EQ(export_buffer(2, O_RDWR, &exported), -EINVAL) << "index beyond the buffers";
  EXPECT_EQ(export_buffer(0, O_RDWR | O_APPEND, &exported), -EINVAL)
      << "flags other than access and cloexec";
  v4l2_exportbuffer plane{};
  plane.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  plane.plane = 1;
  EXPECT_EQ(io->ioctl(fd, VIDIOC_EXPBUF, &plane), -1);
  ASSERT_EQ(reqbufs(2, V4L2_MEMORY_DMABUF), 2);
  EXPECT_EQ(export_buffer(0, O_RDWR, &exported), -EINVAL) << "imported buffers cannot be exported";
}

TEST_F(BufferSharing, DmabufImportRendersIntoTheClientsMemory) {
  const std::vector<uint8_t> expected = mmap_frame();
  ASSERT_EQ(reqbufs(2, V4L2_MEMORY_DMABUF), 2);
  int memfds[2] = {make_memfd(kFrameBytes), make_memfd(2 * kFrameBytes)};
  v4l2_buffer queried{};
  queried.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  queried.index = 1;
  ASSERT_EQ(io->ioctl(fd, VIDIOC_QUERYBUF, &queried), 0);
  EXPECT_EQ(queried.memory, static_cast<uint32_t>(V4L2_MEMORY_DMABUF));
  EXPECT_EQ(queried.length, kFrameBytes) << "sizeimage until a buffer is queued";
  // No memory of the device's own to map.
  EXPECT_EQ(io->mmap(kFrameBytes, PROT_READ, MAP_SHARED, fd, 0), MAP_FAILED);

  v4l2_buffer queued{};
  ASSERT_EQ(queue_dmabuf(0, memfds[0], 0, &queued), 0);
  EXPECT_EQ(queued.m.fd, memfds[0]);
  EXPECT_EQ(queued.length, kFrameBytes) << "length 0 takes the whole buffer (libcamera queues so)";
  EXPECT_NE(queued.flags & V4L2_BUF_FLAG_QUEUED, 0u);
  ASSERT_EQ(queue_dmabuf(1, memfds[1], kFrameBytes), 0);
  ASSERT_EQ(stream(true), 0);
  for (int frame = 0; frame < 4; ++frame) {
    v4l2_buffer done = dequeue(V4L2_MEMORY_DMABUF);
    ASSERT_LT(done.index, 2u);
    EXPECT_EQ(done.m.fd, memfds[done.index]) << "the client's fd is reported back";
    EXPECT_EQ(done.bytesused, kFrameBytes);
    EXPECT_EQ(read_fd(memfds[done.index], kFrameBytes), expected) << "frame " << frame;
    ASSERT_EQ(queue_dmabuf(done.index, memfds[done.index], 0), 0) << "requeued with the same fd";
  }
  ASSERT_EQ(stream(false), 0);
  EXPECT_EQ(reqbufs(0, V4L2_MEMORY_DMABUF), 0);
  for (int m : memfds) close(m);
}

// USERPTR, as uvcvideo offers: the application's own memory gets each frame at DQBUF, the
// same bytes MMAP streaming delivers; QBUF refuses what vb2 refuses.
TEST_F(BufferSharing, UserptrBuffersReceiveTheFrameMmapDelivers) {
  const std::vector<uint8_t> expected = mmap_frame();
  ASSERT_EQ(reqbufs(2, V4L2_MEMORY_USERPTR), 2);
  v4l2_buffer queried{};
  queried.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  queried.index = 1;
  ASSERT_EQ(io->ioctl(fd, VIDIOC_QUERYBUF, &queried), 0);
  EXPECT_EQ(queried.memory, static_cast<uint32_t>(V4L2_MEMORY_USERPTR));
  EXPECT_EQ(queried.length, kFrameBytes) << "sizeimage until a buffer is queued";
  EXPECT_EQ(io->mmap(kFrameBytes, PROT_READ, MAP_SHARED, fd, 0), MAP_FAILED) << "nothing to map";

  auto queue_user = [&](uint32_t index, void* pointer, uint32_t length) {
    v4l2_buffer b{};
    b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    b.memory = V4L2_MEMORY_USERPTR;
    b.index = index;
    b.m.userptr = reinterpret_cast<unsigned long>(pointer);
    b.length = length;
    return io->ioctl(fd, VIDIOC_QBUF, &b) == 0 ? 0 : -errno;
  };
  std::vector<std::vector<uint8_t>> memory(2, std::vector<uint8_t>(kFrameBytes + 100, 0xAB));
  EXPECT_EQ(queue_user(0, nullptr, kFrameBytes), -EINVAL) << "no pointer";
  EXPECT_EQ(queue_user(0, memory[0].data(), kFrameBytes - 1), -EINVAL) << "shorter than a frame";
  // An address nothing is mapped at: a page reserved and then given back.
  void* gone =
      mmap(nullptr, kFrameBytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  ASSERT_NE(gone, MAP_FAILED);
  munmap(gone, kFrameBytes);
  EXPECT_EQ(queue_user(0, gone, kFrameBytes), -EFAULT) << "memory the application lacks";

  for (uint32_t i = 0; i < 2; ++i) ASSERT_EQ(queue_user(i, memory[i].data(), kFrameBytes + 100), 0);
  ASSERT_EQ(stream(true), 0);
  for (int frame = 0; frame < 4; ++frame) {
    v4l2_buffer done = dequeue(V4L2_MEMORY_USERPTR);
    ASSERT_LT(done.index, 2u);
    EXPECT_EQ(done.m.userptr, reinterpret_cast<unsigned long>(memory[done.index].data()));
    EXPECT_EQ(done.length, kFrameBytes + 100) << "the length QBUF gave";
    EXPECT_EQ(done.bytesused, kFrameBytes);
    EXPECT_TRUE(std::equal(expected.begin(), expected.end(), memory[done.index].begin()))
        << "frame " << frame;
    EXPECT_EQ(memory[done.index][kFrameBytes], 0xAB) << "nothing written past bytesused";
    std::fill(memory[done.index].begin(), memory[done.index].end(), 0xAB);
    ASSERT_EQ(queue_user(done.index, memory[done.index].data(), kFrameBytes + 100), 0);
  }
  ASSERT_EQ(stream(false), 0);
  EXPECT_EQ(reqbufs(0, V4L2_MEMORY_USERPTR), 0);
}

TEST_F(BufferSharing, DmabufQbufRejectsWhatVb2Rejects) {
  ASSERT_EQ(reqbufs(2, V4L2_MEMORY_DMABUF), 2);
  const int small = make_memfd(kFrameBytes / 2);
  const int exact = make_memfd(kFrameBytes);
  EXPECT_EQ(queue_dmabuf(0, -1, 0), -EINVAL);
  EXPECT_EQ(queue_dmabuf(0, 0xdeadbeef, 0), -EINVAL) << "not an fd";
  EXPECT_EQ(queue_dmabuf(0, small, 0), -EINVAL) << "shorter than sizeimage";
  EXPECT_EQ(queue_dmabuf(0, exact, 2 * kFrameBytes), -EFAULT) << "length beyond the buffer";
  v4l2_buffer wrong_memory{};
  wrong_memory.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  wrong_memory.memory = V4L2_MEMORY_MMAP;
  EXPECT_EQ(io->ioctl(fd, VIDIOC_QBUF, &wrong_memory), -1);
  EXPECT_EQ(errno, EINVAL);
  EXPECT_EQ(queue_dmabuf(0, exact, 0), 0);
  EXPECT_EQ(queue_dmabuf(0, exact, 0), -EINVAL) << "already queued";
  close(small);
  close(exact);
}

// libcamera's UVC path: exportBuffers() (REQBUFS MMAP, EXPBUF, REQBUFS 0), then
// importBuffers() (REQBUFS DMABUF) and queueBuffer() with the exported fds.
TEST_F(BufferSharing, LibcameraExportThenImportSequence) {
  const std::vector<uint8_t> expected = mmap_frame();
  ASSERT_EQ(reqbufs(4, V4L2_MEMORY_MMAP), 4);
  std::vector<int> exported(4, -1);
  for (uint32_t i = 0; i < 4; ++i) ASSERT_EQ(export_buffer(i, O_RDWR, &exported[i]), 0);
  ASSERT_EQ(reqbufs(0, V4L2_MEMORY_MMAP), 0);
  ASSERT_EQ(reqbufs(4, V4L2_MEMORY_DMABUF), 4);
  for (uint32_t i = 0; i < 4; ++i) ASSERT_EQ(queue_dmabuf(i, exported[i], 0), 0);
  ASSERT_EQ(stream(true), 0);
  uint32_t last_sequence = 0;
  for (int frame = 0; frame < 8; ++frame) {
    v4l2_buffer done = dequeue(V4L2_MEMORY_DMABUF);
    if (frame > 0) {
      EXPECT_GT(done.sequence, last_sequence);
    }
    last_sequence = done.sequence;
    EXPECT_EQ(read_fd(exported[done.index], kFrameBytes), expected);
    ASSERT_EQ(queue_dmabuf(done.index, exported[done.index], 0), 0);
  }
  ASSERT_EQ(stream(false), 0);
  ASSERT_EQ(reqbufs(0, V4L2_MEMORY_DMABUF), 0);
  for (int e : exported) close(e);
}

// A transport serving another process passes its own fd for the buffer while m.fd
// stays the client's number, which is what QBUF and DQBUF report back.
TEST_F(BufferSharing, TransportFdIsUsedAndTheClientsNumberReported) {
  const int file = device->open_file(false);
  v4l2_requestbuffers request{};
  request.count = 2;
  request.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  request.memory = V4L2_MEMORY_DMABUF;
  ASSERT_EQ(device->ioctl(file, VIDIOC_REQBUFS, &request), 0);
  const int local = make_memfd(kFrameBytes);
  v4l2_buffer b{};
  b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  b.memory = V4L2_MEMORY_DMABUF;
  b.index = 0;
  b.m.fd = 4321;  // meaningless here: the client's fd number
  ASSERT_EQ(device->ioctl(file, VIDIOC_QBUF, &b, local), 0);
  EXPECT_EQ(b.m.fd, 4321);
  int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  ASSERT_EQ(device->ioctl(file, VIDIOC_STREAMON, &type), 0);
  v4l2_buffer done{};
  done.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  done.memory = V4L2_MEMORY_DMABUF;
  ASSERT_EQ(device->ioctl(file, VIDIOC_DQBUF, &done), 0);
  EXPECT_EQ(done.m.fd, 4321);
  EXPECT_NE(read_fd(local, kFrameBytes), std::vector<uint8_t>(kFrameBytes, 0))
      << "rendered into our memfd";
  close(local);  // the device keeps its mapping, not the fd
  ASSERT_EQ(device->ioctl(file, VIDIOC_STREAMOFF, &type), 0);
  device->close_file(file);
}

}  // namespace
}  // namespace camlab::mock
