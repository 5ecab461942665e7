#include "mock_device/broker/vcam_devices.h"

#include <chrono>

#include "mock_device/spec/default_specs.h"
#include "mock_device/spec/rig_spec.h"

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

Result<std::vector<std::shared_ptr<VirtualV4l2Device>>> create_vcam_rig_devices(
    const std::string& rig_path, bool realtime) {
  RigSpec rig;
  CAMLAB_ASSIGN(rig, load_rig_spec(rig_path));
  return create_vcam_rig_devices(rig, 0, realtime);
}

Result<std::vector<std::shared_ptr<VirtualV4l2Device>>> create_vcam_rig_devices(const RigSpec& rig,
                                                                                int first_index,
                                                                                bool realtime) {
  const auto grid_origin = std::chrono::steady_clock::now();
  std::vector<std::shared_ptr<VirtualV4l2Device>> devices;
  for (size_t i = 0; i < rig.cameras.size(); ++i) {
    const RigCameraSpec& member = rig.cameras[i];
    VirtualDeviceOptions options;
    options.index = first_index + static_cast<int>(i);
    options.seed = static_cast<uint64_t>(i) + 1;
    options.realtime = realtime;
    options.view_every_frames = rig.view_every_frames;
    options.frame_grid_origin =
        grid_origin + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                          std::chrono::duration<double, std::micro>(member.trigger_offset_us));
    std::unique_ptr<VirtualV4l2Device> device;
    CAMLAB_ASSIGN(
        device, VirtualV4l2Device::create(member.camera,
                                          scene_seen_from(rig.scene, member.rt_cam_ref), options));
    devices.push_back(std::move(device));
  }
  return devices;
}

}  // namespace camlab::mock
