// The virtual V4L2 device's ioctl dispatch: what is_supported_ioctl says and what ioctl()
// answers come from one table, and the checks before dispatch keep the kernel's order
// (a gone device, then an unknown file, then an unknown ioctl, then a null argument).
#include <gtest/gtest.h>
#include <linux/videodev2.h>

#include <memory>

#include "mock_device/v4l2/virtual_v4l2_device.h"
#include "test_specs.h"

namespace camlab::mock {
namespace {

constexpr unsigned long kSupported[] = {
    VIDIOC_QUERYCAP,    VIDIOC_ENUM_FMT,      VIDIOC_ENUM_FRAMESIZES, VIDIOC_ENUM_FRAMEINTERVALS,
    VIDIOC_G_FMT,       VIDIOC_TRY_FMT,       VIDIOC_S_FMT,           VIDIOC_G_PARM,
    VIDIOC_S_PARM,      VIDIOC_ENUMINPUT,     VIDIOC_G_INPUT,         VIDIOC_S_INPUT,
    VIDIOC_G_PRIORITY,  VIDIOC_S_PRIORITY,    VIDIOC_QUERYCTRL,       VIDIOC_QUERY_EXT_CTRL,
    VIDIOC_QUERYMENU,   VIDIOC_G_CTRL,        VIDIOC_S_CTRL,          VIDIOC_G_EXT_CTRLS,
    VIDIOC_S_EXT_CTRLS, VIDIOC_TRY_EXT_CTRLS, VIDIOC_SUBSCRIBE_EVENT, VIDIOC_UNSUBSCRIBE_EVENT,
    VIDIOC_DQEVENT,     VIDIOC_REQBUFS,       VIDIOC_QUERYBUF,        VIDIOC_QBUF,
    VIDIOC_DQBUF,       VIDIOC_EXPBUF,        VIDIOC_STREAMON,        VIDIOC_STREAMOFF};
constexpr unsigned long kUnsupported[] = {
    VIDIOC_G_STD,       VIDIOC_S_STD,       VIDIOC_CROPCAP,    VIDIOC_G_SELECTION,
    VIDIOC_CREATE_BUFS, VIDIOC_PREPARE_BUF, VIDIOC_G_FBUF,     VIDIOC_ENUMAUDIO,
    VIDIOC_G_TUNER,     VIDIOC_LOG_STATUS,  VIDIOC_G_JPEGCOMP, VIDIOC_ENUM_DV_TIMINGS};

class VirtualV4l2Dispatch : public ::testing::Test {
 protected:
  void SetUp() override {
    auto camera = parse_camera_spec(testing::pinhole_camera_json(32, 24));
    auto scene = parse_scene_spec(testing::uniform_scene_json());
    ASSERT_TRUE(camera.ok() && scene.ok());
    VirtualDeviceOptions options;
    options.realtime = false;
    auto created = VirtualV4l2Device::create(std::move(*camera), std::move(*scene), options);
    ASSERT_TRUE(created.ok());
    device = std::move(*created);
    file = device->open_file(true);
    ASSERT_GT(file, 0);
  }
  void TearDown() override {
    if (device) device->close_file(file);
  }

  std::unique_ptr<VirtualV4l2Device> device;
  int file = 0;
};

TEST_F(VirtualV4l2Dispatch, SupportedIoctlsAreDispatchedAndOthersAreEnotty) {
  for (unsigned long request : kSupported) {
    EXPECT_TRUE(VirtualV4l2Device::is_supported_ioctl(request)) << std::hex << request;
    EXPECT_EQ(device->ioctl(file, request, nullptr), -EFAULT) << std::hex << request;
  }
  for (unsigned long request : kUnsupported) {
    EXPECT_FALSE(VirtualV4l2Device::is_supported_ioctl(request)) << std::hex << request;
    EXPECT_EQ(device->ioctl(file, request, nullptr), -ENOTTY) << std::hex << request;
  }
}

TEST_F(VirtualV4l2Dispatch, ChecksBeforeDispatchKeepTheKernelsOrder) {
  v4l2_capability cap{};
  EXPECT_EQ(device->ioctl(file + 100, VIDIOC_G_STD, nullptr), -EBADF);  // the file first
  EXPECT_EQ(device->ioctl(file + 100, VIDIOC_QUERYCAP, &cap), -EBADF);
  ASSERT_EQ(device->ioctl(file, VIDIOC_QUERYCAP, &cap), 0);
  EXPECT_STREQ(reinterpret_cast<const char*>(cap.driver), "camlab-vcam");
  device->unplug();
  EXPECT_EQ(device->ioctl(file, VIDIOC_QUERYCAP, &cap), -ENODEV);  // a gone device before all
  EXPECT_EQ(device->ioctl(file + 100, VIDIOC_G_STD, nullptr), -ENODEV);
  EXPECT_EQ(device->open_file(false), -ENODEV);
}

TEST_F(VirtualV4l2Dispatch, PriorityChecksSpanTheParts) {
  const int other = device->open_file(true);
  ASSERT_GT(other, 0);
  uint32_t priority = V4L2_PRIORITY_RECORD;
  ASSERT_EQ(device->ioctl(other, VIDIOC_S_PRIORITY, &priority), 0);
  // Below the device's priority: formats, controls and the queue are EBUSY...
  v4l2_format format{};
  format.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  EXPECT_EQ(device->ioctl(file, VIDIOC_S_FMT, &format), -EBUSY);
  v4l2_control control{V4L2_CID_GAIN, 200};
  EXPECT_EQ(device->ioctl(file, VIDIOC_S_CTRL, &control), -EBUSY);
  v4l2_requestbuffers request{};
  request.count = 2;
  request.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  request.memory = V4L2_MEMORY_MMAP;
  EXPECT_EQ(device->ioctl(file, VIDIOC_REQBUFS, &request), -EBUSY);
  // ...after the queue's own checks, which come first as before.
  request.type = V4L2_BUF_TYPE_VIDEO_OUTPUT;
  EXPECT_EQ(device->ioctl(file, VIDIOC_REQBUFS, &request), -EINVAL);
  // Reading is not limited.
  EXPECT_EQ(device->ioctl(file, VIDIOC_G_CTRL, &control), 0);
  device->close_file(other);
  EXPECT_EQ(device->ioctl(file, VIDIOC_S_CTRL, &control), 0);
}

}  // namespace
}  // namespace camlab::mock
