#include "service/jobs/camera_set.h"

#include "base/log.h"
#include "mock_device/spec/camera_spec.h"
#include "mock_device/spec/default_specs.h"
#include "mock_device/spec/scene_spec.h"
#include "mock_device/v4l2/capture_traits.h"

namespace camlab::service {

Result<std::unique_ptr<CameraSet>> CameraSet::create(const CameraSetOptions& options,
                                                     JobStore& store, Metrics& metrics) {
  std::unique_ptr<CameraSet> set(new CameraSet());
  if (!options.device_paths.empty())
    set->registry_.add_v4l2(device::system_v4l2_io(), "kernel", options.device_paths);
  else if (options.scan_devices)
    set->registry_.add_v4l2(device::system_v4l2_io(), "kernel");
  for (const std::string& path : options.device_paths) {
    bool found = false;
    for (const auto& e : set->registry_.devices()) found = found || e.identity.path == path;
    if (!found)
      log_warning(log::Category::kCameras, "--device %s: not a V4L2 capture device (skipped)",
                  path.c_str());
  }
  const int real_count = static_cast<int>(set->registry_.devices().size());
  capture::CameraTraits device_traits;
  if (!options.device_spec.empty()) {
    auto spec = mock::load_camera_spec(options.device_spec);
    if (!spec) return spec.error();
    device_traits = mock::capture_traits_of(*spec);
  }
  const bool add_virtual =
      options.virtual_cameras == VirtualCameras::kAlways ||
      (options.virtual_cameras == VirtualCameras::kWhenNoneFound && real_count == 0);
  if (add_virtual)
    if (auto s = set->add_virtual_cameras(options, real_count); !s) return s.error();

  for (const device::DeviceEntry& entry : set->registry_.devices()) {
    CameraWorkerOptions worker_options = options.worker;
    worker_options.traits = device_traits;
    if (auto it = set->virtual_devices_.find(entry.identity.id);
        it != set->virtual_devices_.end()) {
      worker_options.spec_latency_frames = it->second->camera().timing.control_latency_frames;
      worker_options.source_extra = set->virtual_sources_[entry.identity.id];
      worker_options.traits = mock::capture_traits_of(it->second->camera());
    }
    const std::string id = entry.identity.id;
    const device::DeviceRegistry* registry = &set->registry_;
    set->workers_.push_back(std::make_unique<CameraWorker>(
        entry, [registry, id] { return registry->open(id); }, worker_options, store, metrics));
  }
  return set;
}

Status CameraSet::add_virtual_cameras(const CameraSetOptions& options, int first_index) {
  nlohmann::json camera_json, scene_json;
  if (options.camera_spec.empty()) {
    camera_json = mock::default_camera_spec_json();
  } else {
    auto spec = mock::load_camera_spec(options.camera_spec);
    if (!spec) return spec.error();
    camera_json = spec->source;
  }
  if (options.scene_spec.empty()) {
    scene_json = mock::default_scene_spec_json();
  } else {
    auto spec = mock::load_scene_spec(options.scene_spec);
    if (!spec) return spec.error();
    scene_json = spec->source;
  }
  std::vector<std::shared_ptr<mock::VirtualV4l2Device>> devices;
  std::vector<std::string> paths;
  for (int i = 0; i < options.virtual_count; ++i) {
    auto camera = mock::parse_camera_spec(camera_json);
    if (!camera) return camera.error();
    auto scene = mock::parse_scene_spec(scene_json);
    if (!scene) return scene.error();
    mock::VirtualDeviceOptions device_options;
    device_options.index = first_index + i;
    device_options.seed = static_cast<uint64_t>(1 + i);
    auto device =
        mock::VirtualV4l2Device::create(std::move(*camera), std::move(*scene), device_options);
    if (!device) return device.error();
    devices.push_back(std::move(*device));
    paths.push_back("/dev/video" + std::to_string(device_options.index));
  }
  virtual_io_ = std::make_shared<mock::VirtualV4l2Io>(devices);
  const size_t before = registry_.devices().size();
  registry_.add_v4l2(virtual_io_, "in-process virtual camera", paths);
  for (size_t i = before; i < registry_.devices().size(); ++i) {
    const std::string& id = registry_.devices()[i].identity.id;
    virtual_devices_[id] = devices[i - before];
    virtual_sources_[id] = {
        {"backend", "virtual"}, {"camera_spec", camera_json}, {"scene_spec", scene_json}};
  }
  return {};
}

CameraSet::~CameraSet() { stop(); }

void CameraSet::start() {
  for (auto& worker : workers_) worker->start();
}

void CameraSet::stop() {
  // Ask every worker to stop first, so cameras wind down in parallel, then join.
  for (auto& worker : workers_) worker->request_stop();
  for (auto& worker : workers_) worker->stop();
}

CameraWorker* CameraSet::find(const std::string& id) const {
  for (const auto& worker : workers_)
    if (worker->id() == id) return worker.get();
  return nullptr;
}

mock::VirtualV4l2Device* CameraSet::virtual_device(const std::string& id) const {
  auto it = virtual_devices_.find(id);
  return it == virtual_devices_.end() ? nullptr : it->second.get();
}

}  // namespace camlab::service
