// libcamera's way of finding a UVC camera (DeviceEnumeratorSysfs, MediaDevice::populate,
// PipelineHandlerUVC::match and UVCCameraData::generateId in libcamera 0.0.3), replayed
// in process on the fake sysfs tree and the in-process transport: if these steps work
// here, the same files and ioctls serve libcamera once a transport redirects /sys and
// routes /dev/media0 (which the preload does; tests/integration/libcamera_test.cpp).
#include <fcntl.h>
#include <gtest/gtest.h>
#include <linux/media.h>
#include <linux/videodev2.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <algorithm>
#include <climits>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "mock_device/v4l2/fake_sysfs.h"
#include "mock_device/v4l2/virtual_v4l2_io.h"
#include "test_specs.h"

namespace camlab::mock {
namespace {

namespace fs = std::filesystem;

std::string first_line(const fs::path& path) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  return line;
}

// lookupDeviceNode(): DEVNAME= from /sys/dev/char/M:m/uevent.
std::string device_node(const fs::path& sys, uint32_t major, uint32_t minor) {
  std::ifstream uevent(sys / "dev/char" / (std::to_string(major) + ":" + std::to_string(minor)) /
                       "uevent");
  for (std::string word; uevent >> word;)
    if (word.rfind("DEVNAME=", 0) == 0) return "/dev/" + word.substr(8);
  return {};
}

class LibcameraEnumeration : public ::testing::Test {
 protected:
  void SetUp() override {
    sys = fs::temp_directory_path() / ("camlab_sysfs_" + std::to_string(getpid()));
    fs::remove_all(sys);
    fs::create_directories(sys);
    ASSERT_TRUE(write_sysfs_tree(sys.string(), {"test pinhole", "second camera"}));
    std::vector<std::shared_ptr<VirtualV4l2Device>> devices;
    for (int i = 0; i < 2; ++i) {
      auto camera = parse_camera_spec(testing::pinhole_camera_json(64, 48));
      auto scene = parse_scene_spec(testing::uniform_scene_json());
      ASSERT_TRUE(camera.ok() && scene.ok());
      VirtualDeviceOptions options;
      options.index = i;
      auto device = VirtualV4l2Device::create(std::move(*camera), std::move(*scene), options);
      ASSERT_TRUE(device.ok());
      devices.push_back(std::move(*device));
    }
    io = std::make_unique<VirtualV4l2Io>(std::move(devices));
  }
  void TearDown() override { fs::remove_all(sys); }

  fs::path sys;
  std::unique_ptr<VirtualV4l2Io> io;
};

TEST_F(LibcameraEnumeration, FindsEachCameraFromBusMediaToItsVideoNodeAndUsbId) {
  std::vector<std::string> media_nodes;
  for (const auto& entry : fs::directory_iterator(sys / "bus/media/devices"))
    media_nodes.push_back(entry.path().filename().string());
  std::sort(media_nodes.begin(), media_nodes.end());
  ASSERT_EQ(media_nodes, (std::vector<std::string>{"media0", "media1"}));

  for (int n = 0; n < 2; ++n) {
    SCOPED_TRACE("camera " + std::to_string(n));
    // MediaDevice::populate(): DEVICE_INFO, then G_TOPOLOGY twice.
    const int media_fd = io->open(("/dev/" + media_nodes[n]).c_str(), O_RDWR);
    ASSERT_GE(media_fd, 0);
    media_device_info info{};
    ASSERT_EQ(io->ioctl(media_fd, MEDIA_IOC_DEVICE_INFO, &info), 0);
    EXPECT_STREQ(info.driver, "uvcvideo");
    media_v2_topology topology{};
    ASSERT_EQ(io->ioctl(media_fd, MEDIA_IOC_G_TOPOLOGY, &topology), 0);
    std::vector<media_v2_entity> entities(topology.num_entities);
    std::vector<media_v2_interface> interfaces(topology.num_interfaces);
    std::vector<media_v2_link> links(topology.num_links);
    topology.ptr_entities = reinterpret_cast<uintptr_t>(entities.data());
    topology.ptr_interfaces = reinterpret_cast<uintptr_t>(interfaces.data());
    topology.ptr_links = reinterpret_cast<uintptr_t>(links.data());
    ASSERT_EQ(io->ioctl(media_fd, MEDIA_IOC_G_TOPOLOGY, &topology), 0);
    io->close(media_fd);

    // The default entity's interface gives the video node's device number, which the
    // sysfs tree turns into a path (DeviceEnumeratorSysfs::populateMediaDevice).
    const media_v2_entity* video = nullptr;
    for (const auto& e : entities)
      if (e.flags & MEDIA_ENT_FL_DEFAULT) video = &e;
    ASSERT_NE(video, nullptr);
    const media_v2_interface* interface = nullptr;
    for (const auto& l : links)
      if ((l.flags & MEDIA_LNK_FL_LINK_TYPE) == MEDIA_LNK_FL_INTERFACE_LINK &&
          l.sink_id == video->id)
        for (const auto& i : interfaces)
          if (i.id == l.source_id) interface = &i;
    ASSERT_NE(interface, nullptr);
    EXPECT_EQ(interface->devnode.major, kVideoMajor);
    const std::string node = device_node(sys, interface->devnode.major, interface->devnode.minor);
    EXPECT_EQ(node, "/dev/video" + std::to_string(n));
    EXPECT_EQ(device_node(sys, kMediaMajor, static_cast<uint32_t>(n)),
              "/dev/media" + std::to_string(n));

    // V4L2VideoDevice::open() on it.
    const int video_fd = io->open(node.c_str(), O_RDWR | O_NONBLOCK);
    ASSERT_GE(video_fd, 0);
    v4l2_capability cap{};
    ASSERT_EQ(io->ioctl(video_fd, VIDIOC_QUERYCAP, &cap), 0);
    EXPECT_STREQ(reinterpret_cast<const char*>(cap.bus_info), info.bus_info)
        << "one device, one bus_info";
    EXPECT_GE(cap.version, (5u << 16)) << "libcamera needs V4L2 API 5.0 or later";
    io->close(video_fd);

    // V4L2Device::devicePath(): realpath of /sys/dev/char/81:N/device, the USB
    // interface; generateId() climbs to a firmware node and reads the USB ids.
    char resolved[PATH_MAX];
    const fs::path device_link = sys / "dev/char" / ("81:" + std::to_string(n)) / "device";
    ASSERT_NE(realpath(device_link.c_str(), resolved), nullptr);
    const fs::path interface_path = resolved;
    EXPECT_EQ(interface_path, fs::path(usb_interface_path(fs::canonical(sys).string(), n)));
    EXPECT_TRUE(fs::exists(interface_path / ("media" + std::to_string(n))))
        << "v4l2-compliance finds the media node beside the video node";
    std::string usb_id = interface_path.filename().string();
    usb_id = usb_id.substr(usb_id.find('-') + 1);
    EXPECT_EQ(usb_id, std::to_string(n + 1) + ":1.0");
    std::string controller;
    for (fs::path up = interface_path.parent_path(); up != up.root_path(); up = up.parent_path())
      if (fs::exists(up / "firmware_node/path")) {
        controller = first_line(up / "firmware_node/path");
        break;
      }
    EXPECT_EQ(controller, kControllerFirmwarePath);
    const std::string id = controller + "-" + usb_id + "-" +
                           first_line(interface_path / "../idVendor") + ":" +
                           first_line(interface_path / "../idProduct");
    EXPECT_EQ(id, std::string("\\_SB_.CAMLAB-") + std::to_string(n + 1) + ":1.0-1d6b:0102");
  }
  EXPECT_EQ(io->open_fd_count(), 0u);
}

TEST_F(LibcameraEnumeration, ClassFoldersStillListTheVideoNodes) {
  for (int n = 0; n < 2; ++n) {
    const fs::path video = sys / "class/video4linux" / ("video" + std::to_string(n));
    EXPECT_EQ(first_line(video / "name"), n == 0 ? "test pinhole" : "second camera");
    EXPECT_EQ(first_line(video / "dev"), "81:" + std::to_string(n));
    EXPECT_EQ(first_line(sys / "class/media" / ("media" + std::to_string(n)) / "dev"),
              "236:" + std::to_string(n));
  }
}

TEST(FakeSysfsPaths, RedirectsExactlyTheTreesPaths) {
  EXPECT_TRUE(is_fake_sysfs_path("/sys/bus/media/devices", 1));
  EXPECT_TRUE(is_fake_sysfs_path("/sys/bus/media", 1));
  EXPECT_TRUE(is_fake_sysfs_path("/sys/class/video4linux/video0/name", 1));
  EXPECT_TRUE(is_fake_sysfs_path("/sys/class/media", 1));
  EXPECT_TRUE(is_fake_sysfs_path("/sys/dev/char/81:0/uevent", 1));
  EXPECT_TRUE(is_fake_sysfs_path("/sys/dev/char/236:1", 2));
  EXPECT_TRUE(is_fake_sysfs_path("/sys/devices/platform/camlab_vcam_hcd.0/usb1/1-1/idVendor", 1));
  EXPECT_FALSE(is_fake_sysfs_path("/sys/dev/char/81:1/uevent", 1)) << "beyond the camera count";
  EXPECT_FALSE(is_fake_sysfs_path("/sys/dev/char/236:10", 2));
  EXPECT_FALSE(is_fake_sysfs_path("/sys/dev/char/810:0", 1));
  EXPECT_FALSE(is_fake_sysfs_path("/sys/dev/char/1:3", 1));
  EXPECT_FALSE(is_fake_sysfs_path("/sys/bus/mediafoo", 1));
  EXPECT_FALSE(is_fake_sysfs_path("/sys/devices/platform/serial8250", 1));
  EXPECT_FALSE(is_fake_sysfs_path("/sys/subsystem/media/devices", 1))
      << "libcamera's first guess must fail";
  EXPECT_FALSE(is_fake_sysfs_path("/dev/video0", 1));
}

}  // namespace
}  // namespace camlab::mock
