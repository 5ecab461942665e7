#include "mock_device/v4l2/fake_sysfs.h"

#include <cctype>
#include <cstring>
#include <filesystem>
#include <fstream>

namespace camlab::mock {

namespace {

namespace fs = std::filesystem;

constexpr std::string_view kHostControllerRelative = "devices/platform/camlab_vcam_hcd.0";

// Writes `text` to `path` (creating its folder); false on failure.
bool write_file(const fs::path& path, const std::string& text) {
  std::error_code ec;
  fs::create_directories(path.parent_path(), ec);
  std::ofstream out(path);
  out << text;
  return static_cast<bool>(out);
}

// A relative symlink at `link` to `target` (both under the same root), replacing an
// old one, so that realpath() inside the tree never leaves it.
bool relative_symlink(const fs::path& target, const fs::path& link) {
  std::error_code ec;
  fs::create_directories(link.parent_path(), ec);
  fs::remove(link, ec);
  fs::create_directory_symlink(fs::relative(target, link.parent_path()), link, ec);
  return !ec;
}

}  // namespace

std::string usb_interface_path(const std::string& root, int index) {
  const std::string port = "1-" + std::to_string(index + 1);
  return root + "/" + std::string(kHostControllerRelative) + "/usb1/" + port + "/" + port + ":1.0";
}

namespace {

// udev's names: characters other than letters, digits and #+-.:=@_ become underscores
// (ID_MODEL).
std::string udev_model_name(std::string model) {
  for (char& c : model)
    if (!std::isalnum(static_cast<unsigned char>(c)) && !std::strchr("#+-.:=@_", c)) c = '_';
  return model;
}

std::string usb_serial(int index) { return "camlab-vcam-" + std::to_string(index); }

}  // namespace

std::string v4l_by_id_name(const std::string& camera_name, int index) {
  return "usb-camlab_" + udev_model_name(camera_name) + "_" + usb_serial(index) + "-video-index0";
}

std::string v4l_by_path_name(int index) {
  return "platform-camlab_vcam_hcd.0-usb-0:" + std::to_string(index + 1) + ":1.0-video-index0";
}

bool write_v4l_links(const std::string& root, const std::vector<std::string>& camera_names) {
  bool ok = true;
  for (size_t i = 0; i < camera_names.size() && ok; ++i) {
    const int index = static_cast<int>(i);
    const fs::path target = "../../video" + std::to_string(i);
    for (const auto& [folder, name] :
         {std::pair<std::string, std::string>{"by-id", v4l_by_id_name(camera_names[i], index)},
          {"by-path", v4l_by_path_name(index)}}) {
      std::error_code ec;
      const fs::path link = fs::path(root) / folder / name;
      fs::create_directories(link.parent_path(), ec);
      fs::remove(link, ec);
      fs::create_symlink(target, link, ec);
      ok = ok && !ec;
    }
  }
  return ok;
}

bool write_udev_database(const std::string& root, const std::vector<std::string>& camera_names) {
  bool ok = true;
  for (size_t i = 0; i < camera_names.size() && ok; ++i) {
    const std::string number = std::to_string(i);
    const std::string port = std::to_string(i + 1);
    const std::string model = udev_model_name(camera_names[i]);
    const std::string serial = usb_serial(static_cast<int>(i));
    ok = write_file(fs::path(root) / "data" / ("c" + std::to_string(kVideoMajor) + ":" + number),
                    "S:v4l/by-id/" + v4l_by_id_name(camera_names[i], static_cast<int>(i)) +
                        "\nS:v4l/by-path/" + v4l_by_path_name(static_cast<int>(i)) +
                        "\n"
                        "I:1\n"
                        "E:ID_V4L_VERSION=2\n"
                        "E:ID_V4L_PRODUCT=" +
                        camera_names[i] +
                        "\n"
                        "E:ID_V4L_CAPABILITIES=:capture:\n"
                        "E:ID_BUS=usb\n"
                        "E:ID_VENDOR=camlab\n"
                        "E:ID_VENDOR_ID=" +
                        kUsbVendorId + "\nE:ID_MODEL=" + model +
                        "\nE:ID_MODEL_ID=" + kUsbProductId + "\nE:ID_SERIAL=camlab_" + model + "_" +
                        serial + "\nE:ID_SERIAL_SHORT=" + serial +
                        "\nE:ID_TYPE=video\nE:ID_USB_DRIVER=uvcvideo\n"
                        "E:ID_PATH=platform-camlab_vcam_hcd.0-usb-0:" +
                        port + ":1.0\n");
  }
  return ok;
}

bool write_sysfs_tree(const std::string& root, int count) {
  std::vector<std::string> names;
  for (int n = 0; n < count; ++n) names.push_back("camlab virtual camera " + std::to_string(n));
  return write_sysfs_tree(root, names);
}

bool write_sysfs_tree(const std::string& root_text, const std::vector<std::string>& camera_names) {
  const fs::path root(root_text);
  const fs::path hcd = root / kHostControllerRelative;
  // udev reads a device's subsystem from its `subsystem` link (the last name only): the
  // bus folders outside the fake tree are not needed.
  bool ok =
      relative_symlink(root / "bus/platform", hcd / "subsystem") &&
      relative_symlink(root / "bus/usb", hcd / "usb1/subsystem") &&
      write_file(hcd / "firmware_node/path", std::string(kControllerFirmwarePath) + "\n") &&
      write_file(hcd / "uevent", "DRIVER=camlab_vcam_hcd\nMODALIAS=platform:camlab_vcam_hcd\n") &&
      write_file(hcd / "usb1/uevent",
                 "MAJOR=189\nMINOR=0\nDEVNAME=bus/usb/001/001\nDEVTYPE=usb_device\n"
                 "DRIVER=usb\nBUSNUM=001\nDEVNUM=001\n") &&
      write_file(hcd / "usb1/idVendor", "1d6b\n") && write_file(hcd / "usb1/idProduct", "0002\n");
  for (size_t i = 0; i < camera_names.size() && ok; ++i) {
    const int n = static_cast<int>(i);
    const std::string number = std::to_string(n);
    const std::string& name = camera_names[i];
    const fs::path interface(usb_interface_path(root_text, n));
    const fs::path usb_device = interface.parent_path();
    const std::string devnum = std::to_string(n + 2);  // 1 is the root hub
    const std::string devnum3 = std::string(3 - std::min<size_t>(3, devnum.size()), '0') + devnum;

    // The USB device: what `lsusb`, libcamera (idVendor, idProduct, removable) and udev read.
    ok = ok && write_file(usb_device / "idVendor", std::string(kUsbVendorId) + "\n") &&
         write_file(usb_device / "idProduct", std::string(kUsbProductId) + "\n") &&
         write_file(usb_device / "bcdDevice", "0100\n") &&
         write_file(usb_device / "manufacturer", "camlab\n") &&
         write_file(usb_device / "product", name + "\n") &&
         write_file(usb_device / "serial", usb_serial(n) + "\n") &&
         write_file(usb_device / "removable", "removable\n") &&
         write_file(usb_device / "speed", "480\n") && write_file(usb_device / "busnum", "1\n") &&
         write_file(usb_device / "devnum", devnum + "\n") &&
         write_file(usb_device / "uevent",
                    "MAJOR=189\nMINOR=" + std::to_string(n + 1) + "\nDEVNAME=bus/usb/001/" +
                        devnum3 +
                        "\nDEVTYPE=usb_device\nDRIVER=usb\nPRODUCT=1d6b/102/100\n"
                        "TYPE=239/2/1\nBUSNUM=001\nDEVNUM=" +
                        devnum3 + "\n");
    // The video-control interface that uvcvideo binds, parent of both nodes.
    ok = ok && relative_symlink(root / "bus/usb", usb_device / "subsystem") &&
         relative_symlink(root / "bus/usb", interface / "subsystem") &&
         write_file(interface / "bInterfaceClass", "0e\n") &&
         write_file(interface / "bInterfaceSubClass", "01\n") &&
         write_file(interface / "bInterfaceNumber", "00\n") &&
         write_file(interface / "interface", name + "\n") &&
         write_file(interface / "uevent",
                    "DEVTYPE=usb_interface\nDRIVER=uvcvideo\nPRODUCT=1d6b/102/100\n"
                    "TYPE=239/2/1\nINTERFACE=14/1/0\n"
                    "MODALIAS=usb:v1D6Bp0102d0100dcEFdsc02dp01ic0Eisc01ip00in00\n");

    const fs::path video = interface / "video4linux" / ("video" + number);
    const std::string video_dev = std::to_string(kVideoMajor) + ":" + number;
    ok = ok &&
         write_file(video / "uevent", "MAJOR=" + std::to_string(kVideoMajor) + "\nMINOR=" + number +
                                          "\nDEVNAME=video" + number + "\n") &&
         write_file(video / "dev", video_dev + "\n") && write_file(video / "name", name + "\n") &&
         write_file(video / "index", "0\n") && relative_symlink(interface, video / "device") &&
         relative_symlink(root / "class/video4linux", video / "subsystem");

    const fs::path media = interface / ("media" + number);
    const std::string media_dev = std::to_string(kMediaMajor) + ":" + number;
    ok = ok &&
         write_file(media / "uevent", "MAJOR=" + std::to_string(kMediaMajor) + "\nMINOR=" + number +
                                          "\nDEVNAME=media" + number + "\n") &&
         write_file(media / "dev", media_dev + "\n") && write_file(media / "model", name + "\n") &&
         relative_symlink(interface, media / "device") &&
         relative_symlink(root / "bus/media", media / "subsystem");

    ok = ok && relative_symlink(video, root / "dev/char" / video_dev) &&
         relative_symlink(media, root / "dev/char" / media_dev) &&
         relative_symlink(video, root / "class/video4linux" / ("video" + number)) &&
         relative_symlink(media, root / "class/media" / ("media" + number)) &&
         relative_symlink(media, root / "bus/media/devices" / ("media" + number));
  }
  return ok;
}

}  // namespace camlab::mock
