// The sysfs a V4L2 or media-controller client reads about the virtual cameras, written
// as a real folder tree (the kernel has no media support on camlab's test machines).
// It is shaped like a USB webcam on a virtual host controller (as dummy_hcd's gadgets
// appear), because libcamera's sysfs enumerator and UVC pipeline handler walk it:
//
//   ROOT/devices/platform/camlab_vcam_hcd.0/                      the host controller
//     firmware_node/path                     "\_SB_.CAMLAB"  (libcamera's controller id)
//     usb1/1-P/                              camera N's USB device, P = N + 1
//       idVendor idProduct bcdDevice manufacturer product serial removable uevent ...
//       1-P:1.0/                             its video-control interface (driver uvcvideo)
//         video4linux/videoN/{uevent,dev,name,index,device -> ../../../1-P:1.0}
//         mediaN/{uevent,dev,model,device -> ../../1-P:1.0}
//   ROOT/dev/char/81:N           -> the videoN folder   (v4l2-ctl, libcamera: DEVNAME=)
//   ROOT/dev/char/236:N          -> the mediaN folder
//   ROOT/class/video4linux/videoN -> the videoN folder  (enumerators)
//   ROOT/class/media/mediaN       -> the mediaN folder
//   ROOT/bus/media/devices/mediaN -> the mediaN folder  (libcamera's DeviceEnumeratorSysfs)
// ROOT stands for /sys; the links are relative, so realpath() stays inside ROOT. Each
// device folder has its `subsystem` link (video4linux, media, usb, platform), from which
// udev names a device's subsystem; the links to /sys/bus/usb and /sys/bus/platform point
// outside the fake tree's folders and are only read, never followed.
//
// Beside it, a udev database (write_udev_database), as udev's rules leave it for a UVC
// camera: UDEV/data/c81:N with v4l_id's ID_V4L_VERSION, ID_V4L_PRODUCT and
// ID_V4L_CAPABILITIES, usb_id's vendor, model and serial, and the /dev/v4l links as
// S: lines. GStreamer's device monitor lists only video nodes whose ID_V4L_VERSION is 2.
// UDEV stands for /run/udev.
//
// A transport (the preload library) must redirect exactly the paths is_fake_sysfs_path()
// accepts into ROOT, and report /dev/videoN and /dev/mediaN as character devices with
// the numbers below.
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace camlab::mock {

// Device numbers of the virtual nodes: /dev/videoN is 81:N (VIDEO_MAJOR), /dev/mediaN is
// kMediaMajor:N (the kernel allocates the media major dynamically; 236 is a typical one).
inline constexpr unsigned kVideoMajor = 81;
inline constexpr unsigned kMediaMajor = 236;

// The USB identity of every virtual camera: the Linux Foundation's webcam gadget
// (g_webcam), as a gadget-based test camera would show.
inline constexpr const char* kUsbVendorId = "1d6b";
inline constexpr const char* kUsbProductId = "0102";
// The ACPI path of the virtual host controller: libcamera's UVC camera ids start with it,
// e.g. "\_SB_.CAMLAB-1:1.0-1d6b:0102" for camera 0.
inline constexpr const char* kControllerFirmwarePath = "\\_SB_.CAMLAB";
// The host controller's folder under /sys.
inline constexpr const char* kHostControllerPath = "/sys/devices/platform/camlab_vcam_hcd.0";

// Writes the udev database entries of the cameras' video nodes under `root` (which must
// exist): root/data/c81:N. Returns false when a file cannot be written.
bool write_udev_database(const std::string& root, const std::vector<std::string>& camera_names);

// Writes the tree for `count` devices under `root` (which must exist), the cameras named
// "camlab virtual camera N". Returns false when a file cannot be written.
bool write_sysfs_tree(const std::string& root, int count);
// The same, with the cameras' names (one per camera; they become the USB product and the
// video node's name).
bool write_sysfs_tree(const std::string& root, const std::vector<std::string>& camera_names);

// The persistent names udev's 60-persistent-v4l.rules give a UVC camera's video node,
// links under /dev/v4l to ../../videoN: by-id from the bus and the USB serial (the model
// and "camlab-vcam-N"), by-path from the port the camera sits on. Rig configurations name
// cameras by them, since /dev/videoN numbers follow the order devices appear in.
//   by-id:   usb-camlab_<model>_camlab-vcam-N-video-index0
//   by-path: platform-camlab_vcam_hcd.0-usb-0:P:1.0-video-index0   (P = N + 1)
std::string v4l_by_id_name(const std::string& camera_name, int index);
std::string v4l_by_path_name(int index);

// Writes root/by-id/NAME and root/by-path/NAME, relative links to ../../videoN, for each
// camera (root stands for /dev/v4l). Returns false when a link cannot be made.
bool write_v4l_links(const std::string& root, const std::vector<std::string>& camera_names);

namespace sysfs_detail {

inline bool starts_with(std::string_view text, std::string_view prefix) {
  return text.substr(0, prefix.size()) == prefix;
}

// `prefix` itself or a path below it (not a sibling that shares its first letters).
inline bool is_under(std::string_view path, std::string_view prefix) {
  return starts_with(path, prefix) && (path.size() == prefix.size() || path[prefix.size()] == '/');
}

// "/sys/dev/char/<major>:N", or a path below it, with N < count.
inline bool is_char_node(std::string_view path, unsigned major, int count) {
  constexpr std::string_view base = "/sys/dev/char/";
  if (!starts_with(path, base)) return false;
  path.remove_prefix(base.size());
  unsigned parsed_major = 0;
  size_t i = 0;
  for (; i < path.size() && i < 4 && path[i] >= '0' && path[i] <= '9'; ++i)
    parsed_major = parsed_major * 10 + (path[i] - '0');
  if (i == 0 || parsed_major != major || i >= path.size() || path[i] != ':') return false;
  path.remove_prefix(i + 1);
  int minor = 0;
  for (i = 0; i < path.size() && i < 6 && path[i] >= '0' && path[i] <= '9'; ++i)
    minor = minor * 10 + (path[i] - '0');
  if (i == 0 || (i < path.size() && path[i] != '/')) return false;
  return minor < count;
}

}  // namespace sysfs_detail

// Whether a /sys path belongs to the fake tree of `count` cameras (the preload redirects
// it to ROOT + path without "/sys"):
//   /sys/class/video4linux, /sys/class/media, /sys/bus/media (and below),
//   /sys/dev/char/81:N and /sys/dev/char/236:N for N < count (and below),
//   /sys/devices/platform/camlab_vcam_hcd.0 (and below).
// Header-only and allocation-free, so the preload library can use it inside interposed
// libc calls without linking this library.
inline bool is_fake_sysfs_path(std::string_view path, int count) {
  using namespace sysfs_detail;
  if (!starts_with(path, "/sys/")) return false;
  return is_under(path, "/sys/class/video4linux") || is_under(path, "/sys/class/media") ||
         is_under(path, "/sys/bus/media") || is_under(path, kHostControllerPath) ||
         is_char_node(path, kVideoMajor, count) || is_char_node(path, kMediaMajor, count);
}

// Whether a /run/udev path is a fake database entry of `count` cameras:
// /run/udev/data/c81:N for N < count.
inline bool is_fake_udev_path(std::string_view path, int count) {
  constexpr std::string_view base = "/run/udev/data/c81:";
  if (!sysfs_detail::starts_with(path, base)) return false;
  path.remove_prefix(base.size());
  if (path.empty() || path.size() > 6) return false;
  int minor = 0;
  for (char c : path) {
    if (c < '0' || c > '9') return false;
    minor = minor * 10 + (c - '0');
  }
  return minor < count;
}

// The sysfs path of camera N's USB interface folder, under `root` ("/sys" for the path
// a client sees): ROOT/devices/platform/camlab_vcam_hcd.0/usb1/1-P/1-P:1.0.
std::string usb_interface_path(const std::string& root, int index);

}  // namespace camlab::mock
