// V4l2Camera::start gives every buffer back when any step fails: the mappings are
// unmapped and the driver is told REQBUFS 0, so the queue is free again for a retry or
// for another client. Each step of start() is failed in turn through a seam in front of
// the virtual camera's V4L2 device.
#include <gtest/gtest.h>
#include <linux/videodev2.h>
#include <sys/mman.h>

#include <cerrno>
#include <chrono>
#include <map>
#include <ostream>
#include <string>

#include "device/v4l2/v4l2_camera.h"
#include "mock_device/v4l2/virtual_v4l2_io.h"
#include "test_specs.h"

namespace camlab {
namespace {

using namespace std::chrono_literals;

// A V4l2Io in front of another that fails one step of start() and keeps count of what
// goes through it: live mappings, and the buffer count of every REQBUFS.
class FailingIo final : public device::V4l2Io {
 public:
  explicit FailingIo(std::shared_ptr<device::V4l2Io> inner) : inner_(std::move(inner)) {}

  // The `ordinal`-th call (0-based) of `request` fails with `error`. 0: none fails.
  unsigned long failing_request = 0;
  int failing_ordinal = 0;
  int error = EIO;
  bool fail_second_mmap = false;
  // REQBUFS with a count > 0 reports this many buffers granted (0: what the driver says).
  uint32_t granted_count = 0;

  std::vector<uint32_t> reqbufs_counts;
  int live_mappings = 0;

  int open(const char* path, int flags) override { return inner_->open(path, flags); }
  int close(int fd) override { return inner_->close(fd); }
  int ioctl(int fd, unsigned long request, void* arg) override {
    if (request == failing_request && calls_[request]++ == failing_ordinal) {
      errno = error;
      return -1;
    }
    if (request == VIDIOC_REQBUFS)
      reqbufs_counts.push_back(static_cast<v4l2_requestbuffers*>(arg)->count);
    const int result = inner_->ioctl(fd, request, arg);
    if (request == VIDIOC_REQBUFS && result == 0 && granted_count > 0) {
      auto* asked = static_cast<v4l2_requestbuffers*>(arg);
      if (asked->count > 0) asked->count = granted_count;
    }
    return result;
  }
  void* mmap(size_t length, int prot, int flags, int fd, off_t offset) override {
    if (fail_second_mmap && ++mmaps_ == 2) {
      errno = ENOMEM;
      return MAP_FAILED;
    }
    void* address = inner_->mmap(length, prot, flags, fd, offset);
    if (address != MAP_FAILED) ++live_mappings;
    return address;
  }
  int munmap(void* address, size_t length) override {
    --live_mappings;
    return inner_->munmap(address, length);
  }
  int poll(struct pollfd* fds, nfds_t count, int timeout_ms) override {
    return inner_->poll(fds, count, timeout_ms);
  }

 private:
  std::shared_ptr<device::V4l2Io> inner_;
  std::map<unsigned long, int> calls_;
  int mmaps_ = 0;
};

struct Failure {
  std::string name;
  unsigned long request;
  int ordinal;
  bool second_mmap;
  uint32_t granted;
};

void PrintTo(const Failure& failure, std::ostream* out) { *out << failure.name; }

class V4l2CameraStartFailure : public ::testing::TestWithParam<Failure> {
 protected:
  void SetUp() override {
    auto camera = mock::parse_camera_spec(mock::testing::pinhole_camera_json(64, 48));
    auto scene = mock::parse_scene_spec(mock::testing::uniform_scene_json(1.0, 0.5));
    ASSERT_TRUE(camera.ok() && scene.ok());
    mock::VirtualDeviceOptions options;
    options.realtime = false;
    auto device = mock::VirtualV4l2Device::create(std::move(*camera), std::move(*scene), options);
    ASSERT_TRUE(device.ok()) << device.error().message;
    device_ = std::move(*device);
    virtual_io_ = std::make_shared<mock::VirtualV4l2Io>(std::vector{device_});
    failing_io_ = std::make_shared<FailingIo>(virtual_io_);
  }

  std::shared_ptr<mock::VirtualV4l2Device> device_;
  std::shared_ptr<mock::VirtualV4l2Io> virtual_io_;
  std::shared_ptr<FailingIo> failing_io_;
};

TEST_P(V4l2CameraStartFailure, GivesEveryBufferBack) {
  const Failure& failure = GetParam();
  failing_io_->failing_request = failure.request;
  failing_io_->failing_ordinal = failure.ordinal;
  failing_io_->fail_second_mmap = failure.second_mmap;
  failing_io_->granted_count = failure.granted;
  auto camera = device::V4l2Camera::open(failing_io_, "/dev/video0");
  ASSERT_TRUE(camera.ok()) << camera.error().message;

  const Status started = (*camera)->start(4);
  ASSERT_FALSE(started.ok()) << failure.name << " did not fail";
  EXPECT_EQ(started.error().code, "io_error") << started.error().message;
  EXPECT_EQ((*camera)->mapped_buffer_count(), 0u);
  EXPECT_EQ(failing_io_->live_mappings, 0) << "every mapping is unmapped";
  ASSERT_FALSE(failing_io_->reqbufs_counts.empty());
  EXPECT_EQ(failing_io_->reqbufs_counts.back(), 0u) << "the driver is told to free the buffers";
  EXPECT_EQ(virtual_io_->mapping_count(), 0u);

  // The queue is free: another client can stream at once (it would get EBUSY while this
  // fd still held the buffers), and so can this camera once the fault is gone.
  auto other = device::V4l2Camera::open(virtual_io_, "/dev/video0");
  ASSERT_TRUE(other.ok());
  ASSERT_TRUE((*other)->start(3).ok()) << "the failed start kept the queue";
  auto frame = (*other)->dequeue(2000ms);
  ASSERT_TRUE(frame.ok()) << frame.error().message;
  ASSERT_TRUE((*other)->stop().ok());
  other->reset();

  failing_io_->failing_request = 0;
  failing_io_->fail_second_mmap = false;
  failing_io_->granted_count = 0;
  ASSERT_TRUE((*camera)->start(4).ok()) << "a retry after the fault must work";
  ASSERT_TRUE((*camera)->stop().ok());
  EXPECT_EQ(failing_io_->live_mappings, 0);
}

INSTANTIATE_TEST_SUITE_P(EveryStep, V4l2CameraStartFailure,
                         ::testing::Values(Failure{"FewerThanTwoBuffersGranted", 0, 0, false, 1},
                                           Failure{"FirstQuerybuf", VIDIOC_QUERYBUF, 0, false, 0},
                                           Failure{"ThirdQuerybuf", VIDIOC_QUERYBUF, 2, false, 0},
                                           Failure{"SecondMmap", 0, 0, true, 0},
                                           Failure{"LastQbuf", VIDIOC_QBUF, 3, false, 0},
                                           Failure{"Streamon", VIDIOC_STREAMON, 0, false, 0}),
                         [](const ::testing::TestParamInfo<Failure>& info) {
                           return info.param.name;
                         });

}  // namespace
}  // namespace camlab
