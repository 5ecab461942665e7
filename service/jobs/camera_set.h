// The cameras camlabd serves: V4L2 devices found through the device registry (every
// /dev/video* capture node, or the --device paths), plus in-process virtual cameras
// (mock_device's V4L2 device core behind a VirtualV4l2Io, run through the same V4L2
// backend as real hardware). By default one virtual camera is added when no real camera
// is found. Each camera gets its worker (service/jobs/camera_worker.h).
//
// Built once at start; thread-safe to read afterwards (workers are thread-safe).
#pragma once

#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "base/result.h"
#include "device/device_registry.h"
#include "mock_device/spec/camera_spec.h"
#include "mock_device/v4l2/virtual_v4l2_device.h"
#include "mock_device/v4l2/virtual_v4l2_io.h"
#include "service/jobs/camera_worker.h"

namespace camlab::service {

enum class VirtualCameras { kWhenNoneFound, kAlways, kNever };

struct CameraSetOptions {
  bool scan_devices = true;               // look at every /dev/video*
  std::vector<std::string> device_paths;  // only these (when non-empty)
  VirtualCameras virtual_cameras = VirtualCameras::kWhenNoneFound;
  std::filesystem::path camera_spec;  // empty: the built-in 640x480 camera
  std::filesystem::path scene_spec;   // empty: the built-in slanted-edge scene
  int virtual_count = 1;
  // A camera spec describing the V4L2 (kernel) cameras' sensor and lens: bit depth, black
  // level, gain unity, iris f-numbers, focal length, focus steps (empty: unknown).
  std::filesystem::path device_spec;
  CameraWorkerOptions worker;
};

class CameraSet {
 public:
  static Result<std::unique_ptr<CameraSet>> create(const CameraSetOptions& options, JobStore& store,
                                                   Metrics& metrics);
  ~CameraSet();

  void start();
  void stop();

  CameraWorker* find(const std::string& id) const;
  const std::vector<std::unique_ptr<CameraWorker>>& workers() const { return workers_; }
  // The in-process virtual device behind camera `id`, for test fault injection; null for
  // any other camera.
  mock::VirtualV4l2Device* virtual_device(const std::string& id) const;

 private:
  CameraSet() = default;
  Status add_virtual_cameras(const CameraSetOptions& options, int first_index);

  device::DeviceRegistry registry_;
  std::shared_ptr<mock::VirtualV4l2Io> virtual_io_;
  std::map<std::string, std::shared_ptr<mock::VirtualV4l2Device>> virtual_devices_;  // by camera id
  std::map<std::string, nlohmann::json> virtual_sources_;                            // by camera id
  std::vector<std::unique_ptr<CameraWorker>> workers_;
};

// The built-in virtual camera and scene (mock_device/examples/camera_640x480.json, and
// scene_slanted_edges.json without its 0.4 m edge), so a fresh machine serves without
// any file.
extern const char* const kBuiltinCameraSpec;
extern const char* const kBuiltinSceneSpec;

}  // namespace camlab::service
