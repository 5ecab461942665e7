#include "mock_device/broker/vcam_devices.h"

#include <nlohmann/json.hpp>

namespace camlab::mock {

SceneSpec default_vcam_scene() {
  const nlohmann::json scene = {
      {"targets", {{{"type", "chessboard"}, {"inner_corners", {9, 6}}, {"square_m", 0.03},
                    {"pose", {{"position_m", {-0.12, -0.075, 0.6}}}}}}}};
  auto parsed = parse_scene_spec(scene);
  return std::move(*parsed);  // a constant scene: parsing it cannot fail
}

Result<std::vector<std::shared_ptr<VirtualV4l2Device>>> create_vcam_devices(const std::string& camera_path,
                                                                           const std::string& scene_path, int count,
                                                                           bool realtime) {
  std::vector<std::shared_ptr<VirtualV4l2Device>> devices;
  for (int i = 0; i < count; ++i) {
    CameraSpec camera;
    CAMLAB_ASSIGN(camera, load_camera_spec(camera_path));
    SceneSpec scene = default_vcam_scene();
    if (!scene_path.empty()) CAMLAB_ASSIGN(scene, load_scene_spec(scene_path));
    VirtualDeviceOptions options;
    options.index = i;
    options.seed = static_cast<uint64_t>(i) + 1;
    options.realtime = realtime;
    std::unique_ptr<VirtualV4l2Device> device;
    CAMLAB_ASSIGN(device, VirtualV4l2Device::create(std::move(camera), std::move(scene), options));
    devices.push_back(std::move(device));
  }
  return devices;
}

}  // namespace camlab::mock
