// Which V4L2 node and which libcamera camera are the same UVC (USB) camera.
//
// libcamera's UVC pipeline handler names a camera from sysfs: the firmware node path of
// the USB controller (the first ancestor of the video node's device with an ACPI
// firmware_node/path or a device-tree of_node), the USB interface's port path without the
// bus number ("1-3.2:1.0" gives "3.2:1.0"), and the device's idVendor:idProduct, joined
// with '-': e.g. "\_SB_.PCI0.XHC_-3.2:1.0-046d:0825". The same computation on a V4L2 node
// (/sys/class/video4linux/videoN/device) gives the id of the libcamera camera behind it,
// so the key does not depend on names, on /dev numbering or on the order of enumeration,
// and two identical webcams on different ports get different keys. It survives a replug
// into the same port, as the V4L2 id (v4l2:<bus_info>) does.
//
// Cameras of other pipelines (CSI sensors behind an ISP) have no such key: their V4L2
// nodes are the ISP's or the receiver's, not cameras of their own, so nothing is merged.
//
// Reentrant (reads sysfs; no state).
#pragma once

#include <optional>
#include <string>

namespace camlab::device {

// The id libcamera's UVC pipeline gives the camera behind V4L2 node `video_path`
// (/dev/videoN), without camlab's "libcamera:" prefix; nullopt when the node is not a USB
// video interface or sysfs lacks what libcamera reads.
std::optional<std::string> libcamera_uvc_id(const std::string& video_path);
// The same with sysfs mounted at `sysfs_root` instead of /sys (for tests on a made tree;
// a device-tree node's path is then relative to `sysfs_root`/firmware/devicetree).
std::optional<std::string> libcamera_uvc_id(const std::string& video_path,
                                            const std::string& sysfs_root);

// Whether a libcamera camera id has the UVC pipeline's shape
// ("<firmware path>-<ports>:<config>.<interface>-<vendor>:<product>").
bool is_libcamera_uvc_id(const std::string& libcamera_id);

}  // namespace camlab::device
