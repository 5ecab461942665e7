// The virtual camera's buffer queue on its own: videobuf2's rules for REQBUFS (count,
// owner, mapped buffers), the buffer states and their FIFO order, DMABUF imports as
// vb2's __prepare_dmabuf checks them, EXPBUF, and the generation that keeps a frame from
// being written into freed memory.
#include "mock_device/v4l2/virtual_v4l2_queue.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/mman.h>
#include <unistd.h>

#include "base/unique_fd.h"

namespace camlab::mock {
namespace {

constexpr uint32_t kSizeImage = 64 * 48;
constexpr int kOwner = 1, kOther = 2;

class VirtualV4l2QueueTest : public ::testing::Test {
 protected:
  int reqbufs(uint32_t count, v4l2_memory memory = V4L2_MEMORY_MMAP, int file = kOwner) {
    v4l2_requestbuffers request{};
    request.count = count;
    request.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    request.memory = memory;
    const int error = queue.reqbufs(file, &request, kSizeImage);
    capabilities = request.capabilities;
    return error < 0 ? error : static_cast<int>(request.count);
  }
  v4l2_buffer buffer(uint32_t index, v4l2_memory memory = V4L2_MEMORY_MMAP) {
    v4l2_buffer b{};
    b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    b.memory = memory;
    b.index = index;
    return b;
  }
  int qbuf(uint32_t index, int file = kOwner) {
    v4l2_buffer b = buffer(index);
    return queue.qbuf(file, &b, -1, kSizeImage);
  }
  int qbuf_dmabuf(uint32_t index, int fd, uint32_t length, v4l2_buffer* out = nullptr) {
    v4l2_buffer b = buffer(index, V4L2_MEMORY_DMABUF);
    b.m.fd = fd;
    b.length = length;
    const int error = queue.qbuf(kOwner, &b, -1, kSizeImage);
    if (out) *out = b;
    return error;
  }
  // The producer's side: fills the oldest queued buffer as frame `sequence`.
  int fill(uint32_t sequence) {
    const int index = queue.start_filling();
    v4l2_buffer done{};
    done.index = static_cast<uint32_t>(index);
    done.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    done.sequence = sequence;
    queue.complete(index, done, kSizeImage);
    return index;
  }
  static UniqueFd make_memfd(size_t bytes) {
    UniqueFd fd(memfd_create("queue-test", MFD_CLOEXEC));
    if (fd && ftruncate(fd.get(), static_cast<off_t>(bytes)) != 0) fd.reset();
    return fd;
  }

  VirtualV4l2Queue queue;
  uint32_t capabilities = 0;
};

TEST_F(VirtualV4l2QueueTest, ReqbufsGivesTwoToThirtyTwoBuffersToOneOwner) {
  constexpr uint32_t kAllMemory =
      V4L2_BUF_CAP_SUPPORTS_MMAP | V4L2_BUF_CAP_SUPPORTS_USERPTR | V4L2_BUF_CAP_SUPPORTS_DMABUF;
  EXPECT_EQ(reqbufs(1), 2);
  EXPECT_EQ(capabilities, kAllMemory);
  EXPECT_EQ(queue.owner(), kOwner);
  EXPECT_EQ(reqbufs(100), 32);  // VB2_MAX_FRAME
  EXPECT_EQ(reqbufs(4, V4L2_MEMORY_MMAP, kOther), -EBUSY);
  EXPECT_EQ(reqbufs(4, V4L2_MEMORY_OVERLAY), -EINVAL);
  EXPECT_EQ(capabilities, kAllMemory);
  EXPECT_TRUE(queue.holds_format());
  EXPECT_EQ(reqbufs(0), 0);  // frees, and gives the queue up
  EXPECT_EQ(queue.owner(), 0);
  EXPECT_FALSE(queue.holds_format());
  EXPECT_EQ(reqbufs(3, V4L2_MEMORY_MMAP, kOther), 3);
}

TEST_F(VirtualV4l2QueueTest, MmapBuffersArePageAlignedMemfdsAtTheirOffsets) {
  ASSERT_EQ(reqbufs(3), 3);
  const auto page = static_cast<size_t>(sysconf(_SC_PAGESIZE));
  const size_t stride = (kSizeImage + page - 1) / page * page;
  for (uint32_t i = 0; i < 3; ++i) {
    v4l2_buffer b = buffer(i);
    ASSERT_EQ(queue.querybuf(&b, kSizeImage), 0);
    EXPECT_EQ(b.m.offset, i * stride);
    EXPECT_EQ(b.length, kSizeImage);
    VirtualV4l2Queue::BufferMemory memory{};
    ASSERT_EQ(queue.buffer_for_mmap(b.m.offset, b.length, &memory), 0);
    EXPECT_GE(memory.memfd, 0);
    EXPECT_EQ(memory.length, stride);
    ASSERT_NE(memory.address, nullptr);
    memory.address[0] = static_cast<uint8_t>(i);  // the device's own mapping is writable
  }
  VirtualV4l2Queue::BufferMemory memory{};
  EXPECT_EQ(queue.buffer_for_mmap(1, kSizeImage, &memory), -EINVAL);  // not a buffer's offset
  EXPECT_EQ(queue.buffer_for_mmap(3 * stride, kSizeImage, &memory), -EINVAL);
  EXPECT_EQ(queue.buffer_for_mmap(0, stride + 1, &memory), -EINVAL);
}

TEST_F(VirtualV4l2QueueTest, MappedBuffersCannotBeFreedAndOutliveTheirOwner) {
  ASSERT_EQ(reqbufs(2), 2);
  v4l2_buffer b = buffer(1);
  ASSERT_EQ(queue.querybuf(&b, kSizeImage), 0);
  queue.note_mapping(b.m.offset, +1);
  ASSERT_EQ(queue.querybuf(&b, kSizeImage), 0);
  EXPECT_TRUE(b.flags & V4L2_BUF_FLAG_MAPPED);
  EXPECT_EQ(reqbufs(2), -EBUSY);  // vb2: still mapped by the client

  // The owner closes: the stream stops, the mapped buffers stay until unmapped.
  const uint64_t generation = queue.generation();
  queue.release(kOwner);
  EXPECT_EQ(queue.owner(), 0);
  EXPECT_EQ(queue.generation(), generation);
  VirtualV4l2Queue::BufferMemory memory{};
  EXPECT_EQ(queue.buffer_for_mmap(b.m.offset, kSizeImage, &memory), 0);
  EXPECT_EQ(reqbufs(2, V4L2_MEMORY_MMAP, kOther), -EBUSY);
  queue.note_mapping(b.m.offset, -1);
  EXPECT_EQ(reqbufs(2, V4L2_MEMORY_MMAP, kOther), 2);
  EXPECT_NE(queue.generation(), generation);
}

TEST_F(VirtualV4l2QueueTest, BuffersAreFilledAndDequeuedInTheOrderQueued) {
  ASSERT_EQ(reqbufs(3), 3);
  EXPECT_EQ(qbuf(0, kOther), -EBUSY);  // only the owner queues
  ASSERT_EQ(qbuf(2), 0);
  ASSERT_EQ(qbuf(0), 0);
  EXPECT_EQ(qbuf(0), -EINVAL);  // already queued
  EXPECT_EQ(qbuf(3), -EINVAL);
  v4l2_buffer b = buffer(2);
  ASSERT_EQ(queue.querybuf(&b, kSizeImage), 0);
  EXPECT_TRUE(b.flags & V4L2_BUF_FLAG_QUEUED);

  ASSERT_EQ(queue.streamon(), 0);
  EXPECT_EQ(fill(7), 2);
  EXPECT_EQ(fill(8), 0);
  EXPECT_FALSE(queue.has_queued());
  ASSERT_TRUE(queue.has_done());
  v4l2_buffer done = buffer(0);
  EXPECT_EQ(queue.check_dqbuf(kOther, done), -EBUSY);
  ASSERT_EQ(queue.check_dqbuf(kOwner, done), 0);
  queue.dqbuf(&done);
  EXPECT_EQ(done.index, 2u);
  EXPECT_EQ(done.sequence, 7u);
  EXPECT_EQ(done.length, kSizeImage);
  EXPECT_FALSE(done.flags & (V4L2_BUF_FLAG_QUEUED | V4L2_BUF_FLAG_DONE));
  queue.dqbuf(&done);
  EXPECT_EQ(done.index, 0u);
  EXPECT_FALSE(queue.has_done());
}

TEST_F(VirtualV4l2QueueTest, StreamoffReturnsEveryBufferAndStopsAFrameBeingFilled) {
  EXPECT_EQ(queue.streamon(), -EINVAL);  // no buffers
  ASSERT_EQ(reqbufs(2), 2);
  ASSERT_EQ(qbuf(0), 0);
  ASSERT_EQ(qbuf(1), 0);
  ASSERT_EQ(queue.streamon(), 0);
  const int index = queue.start_filling();
  const uint64_t generation = queue.generation();
  EXPECT_NE(queue.filling_memory(index, generation), nullptr);
  queue.streamoff();
  EXPECT_EQ(queue.filling_memory(index, generation), nullptr);
  for (uint32_t i = 0; i < 2; ++i) {
    v4l2_buffer b = buffer(i);
    ASSERT_EQ(queue.querybuf(&b, kSizeImage), 0);
    EXPECT_FALSE(b.flags & (V4L2_BUF_FLAG_QUEUED | V4L2_BUF_FLAG_DONE));
  }
  EXPECT_FALSE(queue.has_queued());
}

TEST_F(VirtualV4l2QueueTest, FreedBuffersChangeTheGeneration) {
  ASSERT_EQ(reqbufs(2), 2);
  ASSERT_EQ(qbuf(0), 0);
  ASSERT_EQ(queue.streamon(), 0);
  const int index = queue.start_filling();
  const uint64_t generation = queue.generation();
  queue.release(kOwner);  // nothing mapped: the buffers go
  EXPECT_NE(queue.generation(), generation);
  EXPECT_FALSE(queue.streaming());
  ASSERT_EQ(reqbufs(2, V4L2_MEMORY_MMAP, kOther), 2);
  ASSERT_EQ(qbuf(0, kOther), 0);
  ASSERT_EQ(queue.streamon(), 0);
  EXPECT_EQ(queue.start_filling(), index);
  EXPECT_EQ(queue.filling_memory(index, generation), nullptr);  // not the memory it was
}

TEST_F(VirtualV4l2QueueTest, DmabufImportsFollowPrepareDmabuf) {
  ASSERT_EQ(reqbufs(2, V4L2_MEMORY_DMABUF), 2);
  const UniqueFd small = make_memfd(kSizeImage - 1);
  const UniqueFd exact = make_memfd(kSizeImage);
  ASSERT_TRUE(small && exact);
  EXPECT_EQ(qbuf_dmabuf(0, small.get(), 0), -EINVAL);               // shorter than the format
  EXPECT_EQ(qbuf_dmabuf(0, exact.get(), kSizeImage - 1), -EINVAL);  // asks for too little
  EXPECT_EQ(qbuf_dmabuf(0, exact.get(), kSizeImage + 1), -EFAULT);  // more than the buffer has
  int pipe_fds[2];
  ASSERT_EQ(pipe(pipe_fds), 0);
  const UniqueFd read_end(pipe_fds[0]), write_end(pipe_fds[1]);
  EXPECT_EQ(qbuf_dmabuf(0, read_end.get(), 0), -EINVAL);  // not a buffer
  EXPECT_EQ(qbuf_dmabuf(0, -1, 0), -EINVAL);

  v4l2_buffer queued{};
  ASSERT_EQ(qbuf_dmabuf(0, exact.get(), 0, &queued), 0);  // 0: the whole buffer
  EXPECT_EQ(queued.m.fd, exact.get());
  EXPECT_EQ(queued.length, kSizeImage);
  EXPECT_TRUE(queued.flags & V4L2_BUF_FLAG_QUEUED);

  // The device renders into the client's memory.
  ASSERT_EQ(queue.streamon(), 0);
  const int index = queue.start_filling();
  uint8_t* memory = queue.filling_memory(index, queue.generation());
  ASSERT_NE(memory, nullptr);
  memory[10] = 0x5a;
  uint8_t byte = 0;
  ASSERT_EQ(pread(exact.get(), &byte, 1, 10), 1);
  EXPECT_EQ(byte, 0x5a);

  // Queued again, the same buffer keeps its mapping (as vb2 keeps the attachment).
  v4l2_buffer done{};
  queue.complete(index, done, kSizeImage);
  done = buffer(0, V4L2_MEMORY_DMABUF);
  queue.dqbuf(&done);
  EXPECT_EQ(done.m.fd, exact.get());
  ASSERT_EQ(qbuf_dmabuf(0, exact.get(), kSizeImage), 0);
  EXPECT_EQ(queue.filling_memory(queue.start_filling(), queue.generation()), memory);
}

TEST_F(VirtualV4l2QueueTest, ExpbufGivesANewFdOfTheBuffersMemory) {
  ASSERT_EQ(reqbufs(2), 2);
  v4l2_exportbuffer exported{};
  exported.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  exported.index = 1;
  exported.flags = O_RDONLY | O_NONBLOCK;
  EXPECT_EQ(queue.expbuf(&exported), -EINVAL);  // only O_CLOEXEC and an access mode
  exported.flags = O_RDONLY | O_CLOEXEC;
  ASSERT_EQ(queue.expbuf(&exported), 0);
  const UniqueFd fd(exported.fd);
  EXPECT_EQ(fcntl(fd.get(), F_GETFL) & O_ACCMODE, O_RDONLY);
  EXPECT_TRUE(fcntl(fd.get(), F_GETFD) & FD_CLOEXEC);

  v4l2_buffer b = buffer(1);
  ASSERT_EQ(queue.querybuf(&b, kSizeImage), 0);
  VirtualV4l2Queue::BufferMemory memory{};
  ASSERT_EQ(queue.buffer_for_mmap(b.m.offset, kSizeImage, &memory), 0);
  memory.address[3] = 0xa5;
  uint8_t byte = 0;
  ASSERT_EQ(pread(fd.get(), &byte, 1, 3), 1);
  EXPECT_EQ(byte, 0xa5);

  exported.index = 2;
  EXPECT_EQ(queue.expbuf(&exported), -EINVAL);
  ASSERT_EQ(reqbufs(2, V4L2_MEMORY_DMABUF), 2);
  exported.index = 0;
  EXPECT_EQ(queue.expbuf(&exported), -EINVAL);  // imported buffers are not the device's
}

}  // namespace
}  // namespace camlab::mock
