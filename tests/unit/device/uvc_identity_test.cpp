// device/uvc_identity.h on sysfs trees made here as the kernel lays them out for a USB
// webcam (an interface folder under its device, under the host controller, the video
// node's class link pointing at the interface), with the ids libcamera's UVC pipeline
// gives such cameras: "<controller firmware path>-<ports>:<config>.<interface>-<vid>:<pid>".
#include "device/uvc_identity.h"

#include <gtest/gtest.h>
#include <stdlib.h>

#include <filesystem>
#include <fstream>
#include <string>

namespace camlab::device {
namespace {

namespace fs = std::filesystem;

class UvcIdentity : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string pattern = (fs::temp_directory_path() / "camlab_sysfs_XXXXXX").string();
    ASSERT_NE(::mkdtemp(pattern.data()), nullptr);
    root_ = fs::path(pattern) / "sys";
    fs::create_directories(root_ / "class/video4linux");
  }
  void TearDown() override { fs::remove_all(root_.parent_path()); }

  static void write(const fs::path& file, const std::string& text) {
    fs::create_directories(file.parent_path());
    std::ofstream(file) << text << "\n";
  }
  // A webcam on `ports` (e.g. "1-3.2") of a controller at `controller` (relative to
  // devices/), with its interface 1.0 as /dev/video<n>'s device.
  fs::path add_webcam(int n, const std::string& controller, const std::string& ports,
                      const std::string& vid, const std::string& pid) {
    const fs::path device = root_ / "devices" / controller / "usb1" / ports;
    const fs::path interface = device / (ports + ":1.0");
    write(device / "idVendor", vid);
    write(device / "idProduct", pid);
    fs::create_directories(interface / "video4linux" / ("video" + std::to_string(n)));
    const fs::path node = root_ / "class/video4linux" / ("video" + std::to_string(n));
    fs::create_directories(node);
    fs::create_directory_symlink(interface, node / "device");
    return root_ / "devices" / controller;
  }
  std::optional<std::string> id_of(int n) const {
    return libcamera_uvc_id("/dev/video" + std::to_string(n), root_.string());
  }

  fs::path root_;
};

TEST_F(UvcIdentity, AnAcpiControllerGivesLibcamerasId) {
  const fs::path controller = add_webcam(0, "pci0000:00/0000:00:14.0", "1-3.2", "046d", "0825");
  write(controller / "firmware_node/path", "\\_SB_.PCI0.XHC_");
  EXPECT_EQ(id_of(0), "\\_SB_.PCI0.XHC_-3.2:1.0-046d:0825");
}

TEST_F(UvcIdentity, ADeviceTreeControllerGivesItsNodePath) {
  const fs::path controller = add_webcam(2, "platform/soc/3f980000.usb", "1-1", "1d6b", "0102");
  const fs::path of_node = root_ / "firmware/devicetree/base/soc/usb@7e980000";
  fs::create_directories(of_node);
  fs::create_directory_symlink(of_node, controller / "of_node");
  EXPECT_EQ(id_of(2), "/base/soc/usb@7e980000-1:1.0-1d6b:0102");
}

TEST_F(UvcIdentity, TwoIdenticalWebcamsOnTwoPortsHaveTwoIds) {
  const fs::path controller = add_webcam(0, "pci0000:00/0000:00:14.0", "1-1", "046d", "0825");
  add_webcam(1, "pci0000:00/0000:00:14.0", "1-2", "046d", "0825");
  write(controller / "firmware_node/path", "\\_SB_.PCI0.XHC_");
  ASSERT_TRUE(id_of(0) && id_of(1));
  EXPECT_NE(*id_of(0), *id_of(1));
  EXPECT_EQ(id_of(1), "\\_SB_.PCI0.XHC_-2:1.0-046d:0825");
}

TEST_F(UvcIdentity, NodesThatAreNotUsbCamerasHaveNone) {
  EXPECT_EQ(id_of(7), std::nullopt);  // no such node
  // A platform capture node (a CSI receiver): no USB interface, no ids.
  const fs::path device = root_ / "devices/platform/fe801000.csi";
  fs::create_directories(device);
  fs::create_directories(root_ / "class/video4linux/video3");
  fs::create_directory_symlink(device, root_ / "class/video4linux/video3/device");
  EXPECT_EQ(id_of(3), std::nullopt);
  // A USB camera under a controller with no firmware node anywhere above it.
  add_webcam(4, "pci0000:00/0000:00:1d.0", "2-1", "046d", "0825");
  EXPECT_EQ(id_of(4), std::nullopt);
}

TEST(UvcIdShape, OnlyTheUvcPipelinesIdsHaveIt) {
  EXPECT_TRUE(is_libcamera_uvc_id("\\_SB_.PCI0.XHC_-3.2:1.0-046d:0825"));
  EXPECT_TRUE(is_libcamera_uvc_id("\\_SB_.CAMLAB-1:1.0-1d6b:0102"));
  EXPECT_FALSE(is_libcamera_uvc_id("/base/soc/i2c0mux/i2c@1/imx219@10"));
  EXPECT_FALSE(is_libcamera_uvc_id(""));
}

}  // namespace
}  // namespace camlab::device
