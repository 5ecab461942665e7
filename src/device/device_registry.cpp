#include "device/device_registry.h"

#include <algorithm>
#include <filesystem>

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
    entries_.push_back({identity, transport});
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

Status DeviceRegistry::add_libcamera() {
#ifdef CAMLAB_HAVE_LIBCAMERA
  auto cameras = list_libcamera_cameras();
  if (!cameras) return cameras.error();
  for (auto& identity : *cameras) {
    entries_.push_back({std::move(identity), "libcamera"});
    ios_.push_back(nullptr);
  }
  return {};
#else
  return make_error("unsupported",
                    "camlab was built without libcamera (CAMLAB_WITH_LIBCAMERA=OFF)");
#endif
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
