#include "device/uvc_identity.h"

#include <stdlib.h>
#include <sys/stat.h>

#include <fstream>
#include <memory>
#include <regex>

namespace camlab::device {

namespace {

std::optional<std::string> real_path(const std::string& path) {
  std::unique_ptr<char, decltype(&::free)> resolved(::realpath(path.c_str(), nullptr), &::free);
  if (!resolved) return std::nullopt;
  return std::string(resolved.get());
}

std::optional<std::string> first_line(const std::string& path) {
  std::ifstream in(path);
  std::string line;
  if (!in || !std::getline(in, line)) return std::nullopt;
  while (!line.empty() && (line.back() == '\n' || line.back() == '\r' || line.back() == ' '))
    line.pop_back();
  return line;
}

// libcamera's sysfs::firmwareNodePath: the device-tree path of `device`'s of_node, or its
// ACPI path; empty when it has neither.
std::string firmware_node_path(const std::string& device, const std::string& sysfs_root) {
  struct stat st {};
  if (::stat((device + "/of_node").c_str(), &st) == 0) {
    auto of_path = real_path(device + "/of_node");
    if (!of_path) return {};
    const std::string prefix = sysfs_root + "/firmware/devicetree";
    if (of_path->rfind(prefix, 0) == 0) return of_path->substr(prefix.size());
    return *of_path;
  }
  return first_line(device + "/firmware_node/path").value_or("");
}

}  // namespace

std::optional<std::string> libcamera_uvc_id(const std::string& video_path) {
  return libcamera_uvc_id(video_path, "/sys");
}

std::optional<std::string> libcamera_uvc_id(const std::string& video_path,
                                            const std::string& sysfs_root) {
  const size_t slash = video_path.rfind('/');
  const std::string node = slash == std::string::npos ? video_path : video_path.substr(slash + 1);
  if (node.rfind("video", 0) != 0) return std::nullopt;
  // The USB interface the node belongs to, e.g. /sys/devices/.../usb1/1-3/1-3:1.0.
  auto path = real_path(sysfs_root + "/class/video4linux/" + node + "/device");
  if (!path) return std::nullopt;
  std::string controller;
  for (std::string search = *path;;) {
    const size_t pos = search.rfind('/');
    if (pos == std::string::npos || pos <= sysfs_root.size()) return std::nullopt;
    search.resize(pos);
    controller = firmware_node_path(search, sysfs_root);
    if (!controller.empty()) break;
  }
  std::string usb_id = path->substr(path->rfind('/') + 1);  // "1-3:1.0"
  const size_t dash = usb_id.find('-');
  if (dash == std::string::npos || usb_id.find(':') == std::string::npos) return std::nullopt;
  usb_id = usb_id.substr(dash + 1);  // the bus number is not stable: "3:1.0"
  auto vendor = first_line(*path + "/../idVendor");
  auto product = first_line(*path + "/../idProduct");
  if (!vendor || !product || vendor->empty() || product->empty()) return std::nullopt;
  return controller + "-" + usb_id + "-" + *vendor + ":" + *product;
}

bool is_libcamera_uvc_id(const std::string& libcamera_id) {
  static const std::regex kUvc(R"(.+-[0-9.]+:[0-9]+\.[0-9]+-[0-9a-fA-F]{4}:[0-9a-fA-F]{4})");
  return std::regex_match(libcamera_id, kUvc);
}

}  // namespace camlab::device
