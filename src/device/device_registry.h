// The device registry: which cameras exist, under stable ids, and opening one by id.
//
// V4L2 devices are found as /dev/video* character devices that answer VIDIOC_QUERYCAP
// as streaming capture devices (metadata and output nodes are skipped). Their id is
// "v4l2:<bus_info>", which survives renumbering of /dev/video* across replugs; a second
// capture node on the same bus gets ":<n>" appended. libcamera cameras (when camlab is
// built with libcamera) are "libcamera:<libcamera id>".
//
// A UVC camera is reachable both ways: as its V4L2 node and as the libcamera camera on
// it. merge_twins() lists it once, under the preferred backend, matching the two by the
// key in device/uvc_identity.h (libcamera's own camera id, computed from the node's
// sysfs); the entry kept names the other in `also_reachable_as`.
//
// Thread-compatible.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "device/camera.h"
#include "device/v4l2/v4l2_io.h"

namespace camlab::device {

struct DeviceEntry {
  CameraIdentity identity;
  std::string transport;          // "kernel", or "in-process" for the virtual camera's seam
  std::string also_reachable_as;  // the id of the same camera under the other backend
  // For a libcamera camera on a UVC node: that node (/dev/videoN), whose presence says
  // whether the camera is plugged in (libcamera without udev does not see unplugs).
  std::string v4l2_node;
};

class DeviceRegistry {
 public:
  // Scans `paths` (default: every /dev/video*) through `io`.
  void add_v4l2(std::shared_ptr<V4l2Io> io, const std::string& transport,
                std::vector<std::string> paths = {});
  // Adds every camera libcamera enumerates (transport "libcamera"); a camera that is
  // also a V4L2 node appears once per backend. "unsupported" when camlab was built
  // without libcamera (libcamera_supported()), "io_error" when libcamera cannot start.
  Status add_libcamera();
  // The same in two steps, so that a listing can be kept and added again.
  static Result<std::vector<CameraIdentity>> list_libcamera();
  void add_libcamera(std::vector<CameraIdentity> cameras);
  static bool libcamera_supported();
  // After add_v4l2 (kernel devices) and add_libcamera: each camera reachable both ways is
  // listed once, under libcamera when `prefer_libcamera`, else under V4L2. A libcamera
  // camera with a UVC id whose V4L2 node is not present (checked among every
  // /dev/video*, opened through `io`) is unplugged and left out.
  void merge_twins(bool prefer_libcamera, const std::shared_ptr<V4l2Io>& io);
  const std::vector<DeviceEntry>& devices() const { return entries_; }
  Result<std::unique_ptr<Camera>> open(const std::string& id) const;

 private:
  std::vector<DeviceEntry> entries_;
  std::vector<std::shared_ptr<V4l2Io>> ios_;  // parallel to entries_ (null for libcamera's)
};

// /dev/video* paths, sorted by number.
std::vector<std::string> list_video_device_paths();

}  // namespace camlab::device
