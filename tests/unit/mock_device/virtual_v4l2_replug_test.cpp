// The replug fault: a camera unplugged and plugged in again is a new device, as the kernel
// registers one. Files opened before the unplug stay dead (ENODEV, POLLERR|POLLHUP), new
// opens work and stream, the controls are back at their defaults; the media node of the
// camera follows the same rule (EIO on an old file, as an unregistered media node).
#include <gtest/gtest.h>
#include <linux/media.h>
#include <linux/videodev2.h>
#include <poll.h>

#include <memory>

#include "mock_device/v4l2/virtual_media_device.h"
#include "mock_device/v4l2/virtual_v4l2_device.h"
#include "test_specs.h"

namespace camlab::mock {
namespace {

class VirtualV4l2Replug : public ::testing::Test {
 protected:
  void SetUp() override {
    auto camera = parse_camera_spec(testing::pinhole_camera_json(32, 24));
    auto scene = parse_scene_spec(testing::uniform_scene_json());
    ASSERT_TRUE(camera.ok() && scene.ok());
    VirtualDeviceOptions options;
    options.realtime = false;  // a frame as soon as a buffer is queued
    auto created = VirtualV4l2Device::create(std::move(*camera), std::move(*scene), options);
    ASSERT_TRUE(created.ok());
    device = std::move(*created);
  }

  int64_t exposure(int file) {
    v4l2_control control{V4L2_CID_EXPOSURE_ABSOLUTE, 0};
    EXPECT_EQ(device->ioctl(file, VIDIOC_G_CTRL, &control), 0);
    return control.value;
  }

  // REQBUFS (2 MMAP buffers), QBUF both, STREAMON, DQBUF one: 0 or the first -errno.
  int stream_one_frame(int file, v4l2_buffer* out) {
    v4l2_requestbuffers request{};
    request.count = 2;
    request.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    request.memory = V4L2_MEMORY_MMAP;
    if (int e = device->ioctl(file, VIDIOC_REQBUFS, &request)) return e;
    for (uint32_t i = 0; i < request.count; ++i) {
      v4l2_buffer buffer{};
      buffer.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
      buffer.memory = V4L2_MEMORY_MMAP;
      buffer.index = i;
      if (int e = device->ioctl(file, VIDIOC_QBUF, &buffer)) return e;
    }
    int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    if (int e = device->ioctl(file, VIDIOC_STREAMON, &type)) return e;
    if (device->wait_events(file, POLLIN, 5000) & POLLERR) return -EIO;
    *out = {};
    out->type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    out->memory = V4L2_MEMORY_MMAP;
    return device->ioctl(file, VIDIOC_DQBUF, out);
  }

  std::unique_ptr<VirtualV4l2Device> device;
};

TEST_F(VirtualV4l2Replug, OldFilesStayDeadAndANewOpenStreams) {
  const int old_file = device->open_file(true);
  ASSERT_GT(old_file, 0);
  v4l2_buffer frame{};
  ASSERT_EQ(stream_one_frame(old_file, &frame), 0);
  v4l2_control control{V4L2_CID_EXPOSURE_ABSOLUTE, 400};
  ASSERT_EQ(device->ioctl(old_file, VIDIOC_S_CTRL, &control), 0);

  device->unplug();
  EXPECT_TRUE(device->unplugged());
  EXPECT_EQ(device->open_file(true), -ENODEV);
  device->replug();
  EXPECT_FALSE(device->unplugged());

  // The old file belongs to the removed device: ENODEV, and poll says so.
  v4l2_capability cap{};
  EXPECT_EQ(device->ioctl(old_file, VIDIOC_QUERYCAP, &cap), -ENODEV);
  EXPECT_EQ(device->poll_events(old_file, POLLIN) & (POLLERR | POLLHUP), POLLERR | POLLHUP);

  // A new open is a new device: it allocates buffers although the old file never freed
  // them, streams from sequence 0, and its controls are at their defaults (100).
  const int new_file = device->open_file(true);
  ASSERT_GT(new_file, 0);
  EXPECT_EQ(exposure(new_file), 100);
  ASSERT_EQ(stream_one_frame(new_file, &frame), 0);
  EXPECT_EQ(frame.sequence, 0u);
  EXPECT_GT(frame.bytesused, 0u);

  // Closing the old file does not disturb the new one.
  device->close_file(old_file);
  EXPECT_EQ(device->ioctl(new_file, VIDIOC_QUERYCAP, &cap), 0);
  device->close_file(new_file);
}

TEST_F(VirtualV4l2Replug, ReplugOfAPluggedDeviceChangesNothing) {
  const int file = device->open_file(true);
  ASSERT_GT(file, 0);
  v4l2_control control{V4L2_CID_EXPOSURE_ABSOLUTE, 400};
  ASSERT_EQ(device->ioctl(file, VIDIOC_S_CTRL, &control), 0);
  device->replug();
  EXPECT_EQ(exposure(file), 400);
  device->close_file(file);
}

TEST(VirtualMediaReplug, OldFilesAnswerEioAndNewOpensWork) {
  VirtualMediaDevice media({.index = 0,
                            .model = "test pinhole",
                            .bus_info = "platform:camlab-vcam-0",
                            .video_major = 81,
                            .video_minor = 0});
  const int old_file = media.open_file(false);
  ASSERT_GT(old_file, 0);
  media.unplug();
  EXPECT_EQ(media.open_file(false), -ENODEV);
  media.replug();
  media_device_info info{};
  EXPECT_EQ(media.ioctl(old_file, MEDIA_IOC_DEVICE_INFO, &info), -EIO);
  const int new_file = media.open_file(false);
  ASSERT_GT(new_file, 0);
  EXPECT_EQ(media.ioctl(new_file, MEDIA_IOC_DEVICE_INFO, &info), 0);
  EXPECT_STREQ(info.driver, "uvcvideo");
  media.close_file(old_file);
  media.close_file(new_file);
}

}  // namespace
}  // namespace camlab::mock
