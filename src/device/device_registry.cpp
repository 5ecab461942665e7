#include "device/device_registry.h"

#include <algorithm>
#include <filesystem>
#include <map>
#include <set>

#include "device/uvc_identity.h"

#include "device/v4l2/v4l2_camera.h"
#ifdef CAMLAB_HAVE_LIBCAMERA
#include "device/libcamera/libcamera_camera.h"
#endif

namespace camlab::device {

std::vector<std::string> list_video_device_paths() {
  // Video nodes are listed by the kernel in /sys/class/video4linux (also where a
  // user-space device such as camlab's virtual camera announces itself), and appear in
  // /dev; both are read, so a node missing from one is still found.
  std::vector<std::pair<int, std::string>> found;
  auto add = [&](const std::string& name) {
    if (name.rfind("video", 0) != 0 || name.size() == 5) return;
    const std::string number = name.substr(5);
    if (!std::all_of(number.begin(), number.end(), ::isdigit)) return;
    const std::string path = "/dev/" + name;
    if (std::none_of(found.begin(), found.end(), [&](const auto& f) { return f.second == path; }))
      found.emplace_back(std::stoi(number), path);
  };
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator("/sys/class/video4linux", ec))
    add(entry.path().filename().string());
  ec.clear();
  for (const auto& entry : std::filesystem::directory_iterator("/dev", ec))
    add(entry.path().filename().string());
  std::sort(found.begin(), found.end());
  std::vector<std::string> paths;
  for (auto& [n, path] : found) paths.push_back(std::move(path));
  return paths;
}

void DeviceRegistry::add_v4l2(std::shared_ptr<V4l2Io> io, const std::string& transport,
                              std::vector<std::string> paths) {
  if (paths.empty()) paths = list_video_device_paths();
  for (const auto& path : paths) {
    auto camera = V4l2Camera::open(io, path);
    if (!camera) continue;  // not a streaming capture node (metadata, output, gone)
    CameraIdentity identity = (*camera)->identity();
    int duplicates = 0;
    for (const auto& e : entries_) duplicates += e.identity.id.rfind(identity.id, 0) == 0;
    if (duplicates > 0) identity.id += ":" + std::to_string(duplicates);
    entries_.push_back({identity, transport, "", ""});
    ios_.push_back(io);
  }
}

bool DeviceRegistry::libcamera_supported() {
#ifdef CAMLAB_HAVE_LIBCAMERA
  return true;
#else
  return false;
#endif
}

Result<std::vector<CameraIdentity>> DeviceRegistry::list_libcamera() {
#ifdef CAMLAB_HAVE_LIBCAMERA
  return list_libcamera_cameras();
#else
  return make_error("unsupported",
                    "camlab was built without libcamera (CAMLAB_WITH_LIBCAMERA=OFF)");
#endif
}

void DeviceRegistry::add_libcamera(std::vector<CameraIdentity> cameras) {
  for (auto& identity : cameras) {
    entries_.push_back({std::move(identity), "libcamera", "", ""});
    ios_.push_back(nullptr);
  }
}

Status DeviceRegistry::add_libcamera() {
  auto cameras = list_libcamera();
  if (!cameras) return cameras.error();
  add_libcamera(std::move(*cameras));
  return {};
}

void DeviceRegistry::merge_twins(bool prefer_libcamera, const std::shared_ptr<V4l2Io>& io) {
  // Kernel nodes only: in-process virtual cameras are not seen by libcamera.
  std::map<std::string, size_t> v4l2_by_key;
  std::set<std::string> served_paths;
  for (size_t i = 0; i < entries_.size(); ++i) {
    if (entries_[i].identity.backend != "v4l2" || entries_[i].transport != "kernel") continue;
    served_paths.insert(entries_[i].identity.path);
    if (auto key = libcamera_uvc_id(entries_[i].identity.path)) v4l2_by_key.emplace(*key, i);
  }
  // Nodes present but not served (outside --device) still witness their camera.
  std::map<std::string, std::string> present;  // key -> node
  for (const auto& [key, i] : v4l2_by_key) present.emplace(key, entries_[i].identity.path);
  bool need_witness = false;
  for (const auto& e : entries_)
    need_witness = need_witness ||
                   (e.identity.backend == "libcamera" && is_libcamera_uvc_id(e.identity.path) &&
                    !present.contains(e.identity.path));
  if (need_witness && io)
    for (const std::string& path : list_video_device_paths()) {
      if (served_paths.contains(path)) continue;
      if (!V4l2Camera::open(io, path)) continue;  // gone (ENODEV), or not a capture node
      if (auto key = libcamera_uvc_id(path)) present.emplace(*key, path);
    }

  std::vector<bool> drop(entries_.size(), false);
  for (size_t j = 0; j < entries_.size(); ++j) {
    DeviceEntry& lc = entries_[j];
    if (lc.identity.backend != "libcamera") continue;
    const std::string& key = lc.identity.path;  // the libcamera id
    if (auto twin = v4l2_by_key.find(key); twin != v4l2_by_key.end()) {
      DeviceEntry& node = entries_[twin->second];
      lc.v4l2_node = node.identity.path;
      if (prefer_libcamera) {
        drop[twin->second] = true;
        lc.also_reachable_as = node.identity.id;
      } else {
        drop[j] = true;
        node.also_reachable_as = lc.identity.id;
      }
    } else if (auto witness = present.find(key); witness != present.end()) {
      lc.v4l2_node = witness->second;
    } else if (is_libcamera_uvc_id(key)) {
      drop[j] = true;  // its node is gone: unplugged
    }
  }
  std::vector<DeviceEntry> entries;
  std::vector<std::shared_ptr<V4l2Io>> ios;
  for (size_t i = 0; i < entries_.size(); ++i) {
    if (drop[i]) continue;
    entries.push_back(std::move(entries_[i]));
    ios.push_back(std::move(ios_[i]));
  }
  entries_ = std::move(entries);
  ios_ = std::move(ios);
}

Result<std::unique_ptr<Camera>> DeviceRegistry::open(const std::string& id) const {
  std::string known;
  for (size_t i = 0; i < entries_.size(); ++i) {
#ifdef CAMLAB_HAVE_LIBCAMERA
    if (entries_[i].identity.backend == "libcamera" &&
        (entries_[i].identity.id == id || entries_[i].identity.path == id))
      return open_libcamera_camera(entries_[i].identity.id);
#endif
    if (entries_[i].identity.id == id || entries_[i].identity.path == id) {
      auto camera = V4l2Camera::open(ios_[i], entries_[i].identity.path);
      if (!camera) return camera.error();
      return std::unique_ptr<Camera>(std::move(*camera));
    }
    known += (known.empty() ? "" : ", ") + entries_[i].identity.id;
  }
  return make_error("no_device",
                    "no camera with id '" + id + "'" +
                        (known.empty() ? " (no cameras found)" : " (cameras: " + known + ")"));
}

}  // namespace camlab::device
