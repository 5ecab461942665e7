#include "device/device_registry.h"

#include <algorithm>
#include <filesystem>

#include "device/v4l2_camera.h"

namespace camlab::device {

std::vector<std::string> list_video_device_paths() {
  std::vector<std::pair<int, std::string>> found;
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator("/dev", ec)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind("video", 0) != 0 || name.size() == 5) continue;
    const std::string number = name.substr(5);
    if (!std::all_of(number.begin(), number.end(), ::isdigit)) continue;
    found.emplace_back(std::stoi(number), entry.path().string());
  }
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

Result<std::unique_ptr<Camera>> DeviceRegistry::open(const std::string& id) const {
  std::string known;
  for (size_t i = 0; i < entries_.size(); ++i) {
    if (entries_[i].identity.id == id || entries_[i].identity.path == id) {
      auto camera = V4l2Camera::open(ios_[i], entries_[i].identity.path);
      if (!camera) return camera.error();
      return std::unique_ptr<Camera>(std::move(*camera));
    }
    known += (known.empty() ? "" : ", ") + entries_[i].identity.id;
  }
  return make_error("no_device", "no camera with id '" + id + "'" +
                                     (known.empty() ? " (no cameras found)" : " (cameras: " + known + ")"));
}

}  // namespace camlab::device
