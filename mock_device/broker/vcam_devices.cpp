#include "mock_device/broker/vcam_devices.h"

#include "mock_device/spec/default_specs.h"

namespace camlab::mock {

Result<std::vector<std::shared_ptr<VirtualV4l2Device>>> create_vcam_devices(
    const std::string& camera_path, const std::string& scene_path, int count, bool realtime) {
  std::vector<std::shared_ptr<VirtualV4l2Device>> devices;
  for (int i = 0; i < count; ++i) {
    CameraSpec camera = default_camera_spec();
    if (!camera_path.empty()) CAMLAB_ASSIGN(camera, load_camera_spec(camera_path));
    SceneSpec scene = default_scene_spec();
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
